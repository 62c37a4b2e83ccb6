"""A headless PyBullet world that owns its own physics client.

Every :class:`PhysicsWorld` connects its own client (``p.DIRECT`` by default) and passes
its ``client`` id to every PyBullet call, so several worlds coexist in one process and
nothing ever touches PyBullet's implicit default client.

One setting is *not* per client: Bullet's contact breaking threshold is a C++ global
(``gContactBreakingThreshold``) that ``setPhysicsEngineParameter(contactBreakingThreshold=...)``
overwrites for every client of the process, whatever ``physicsClientId`` it is given (checked
with pybullet 3.2.7: a 2 cm world stepped after a 4 mm world was connected followed the 4 mm
world's contacts exactly). Manifolds take the value current when they are created, and the
broadphase box margins the value current at each step, so :meth:`PhysicsWorld.step` sets its
own threshold before stepping: worlds with different thresholds can then alternate in one
process without either seeing the other's.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, replace
from types import MappingProxyType, TracebackType

import pybullet as p

GRAVITY_M_S2 = 9.81
#: Bumped whenever a change to this engine's physics settings can change the outcome of every
#: skill's trials; benchmark caches key their trials by :func:`physics_version`
#: (``bench/fidelity.py``), which adds a per-skill revision.
PHYSICS_VERSION = 1
#: Per-skill revisions on top of :data:`PHYSICS_VERSION`, bumped when a change touches one
#: skill's world only (so the other skills' cached trials stay valid). ``push`` 1: its world's
#: 2 cm contact breaking threshold (issue #20, :data:`SKILL_CONTACT_BREAKING_M`). ``scoop`` 1:
#: 50 solver iterations (issues #20/#21, :data:`SKILL_SOLVER_ITERATIONS`), so 5-iteration
#: scoop trials (cached, pooled or recorded as ``pybullet@v1``) never mix with new ones.
SKILL_PHYSICS_REVISIONS: Mapping[str, int] = MappingProxyType({"push": 1, "scoop": 1})

#: Solver iterations per step of each Kitchen3D skill's world (the reference implementation
#: runs PyBullet at its default, 50). The scoop takes 50: with 5 its labels agreed with 50's
#: on 189/200 random valid inputs (Wilson 0.904-0.969, below the 0.95 rule), every one of the
#: 11 disagreements a success only 50 reproduces (sign test p = 0.001: a bias, not label
#: noise; ``models/README.md``, ``docs/results/fidelity/scoop_solver.json``); a scoop trial
#: costs ~1.7x the CPU (9.1 vs 5.5 s). Pour, push and stir keep 5 (their ``3d-<skill>-solver``
#: rows). A backend's ``solver_iterations`` option replaces them all (a what-if).
SKILL_SOLVER_ITERATIONS: Mapping[str, int] = MappingProxyType({
    "pour": 5,
    "scoop": 50,
    "push": 5,
    "stir": 5,
})

#: Contact breaking threshold (m) of the bead worlds: Bullet's default (2 cm) keeps a
#: manifold for every bead within 2 cm of a 6 mm bead; 4 mm makes bead piles 2-4x faster with
#: the same settled heap.
BEAD_CONTACT_BREAKING_M = 0.004
#: Bullet's own default contact breaking threshold (m), used by the push world.
BULLET_DEFAULT_CONTACT_BREAKING_M = 0.02

#: Contact breaking threshold (m) of each Kitchen3D skill's world.
#:
#: Pour, scoop and stir simulate bead piles and keep :data:`BEAD_CONTACT_BREAKING_M`. The push
#: (a fingertip pad sliding a block, no beads) uses Bullet's default 2 cm (issue #20): with
#: 4 mm each step leaves a single pad-on-block contact point, a different corner of the pad
#: face each step, so an off-centre push twists the block at random and its label is chaotic:
#: on the 200 inputs of ``bench/fidelity.py``'s ``3d-push-engine`` row it survived 0.1-0.2 mm
#: sideways pad shifts on 182/200 (SAPIEN 200/200), and PyBullet 5 vs 50 solver iterations
#: agreed on 0.935. With 2 cm the pad keeps 2-3 contact points on the block; the label
#: survives the shifts on 195/200 and PyBullet vs SAPIEN agree on 191/200 = 0.955 (was 0.940);
#: 9 of the 200 PyBullet push labels change (``bench/push_sensitivity.py``,
#: ``docs/results/fidelity/push_sensitivity*.json``, ``models/README.md``). A push trial costs
#: about the same either way (it has no bead piles).
SKILL_CONTACT_BREAKING_M: Mapping[str, float] = MappingProxyType({
    "pour": BEAD_CONTACT_BREAKING_M,
    "scoop": BEAD_CONTACT_BREAKING_M,
    "stir": BEAD_CONTACT_BREAKING_M,
    "push": BULLET_DEFAULT_CONTACT_BREAKING_M,
})


def physics_version(skill: str) -> str:
    """The physics version of ``skill``'s PyBullet trials, as cache keys carry it:
    ``"<PHYSICS_VERSION>"``, or ``"<PHYSICS_VERSION>.<revision>"`` for a skill with a
    revision in :data:`SKILL_PHYSICS_REVISIONS` (push: ``"1.1"``; pour, scoop, stir: ``"1"``,
    as before the push's own revision, so their cached trials stay valid)."""
    revision = SKILL_PHYSICS_REVISIONS.get(skill, 0)
    return f"{PHYSICS_VERSION}" if revision == 0 else f"{PHYSICS_VERSION}.{revision}"


@dataclass(frozen=True)
class WorldConfig:
    """Simulation settings: ``time_step`` in seconds, solver iterations per step and the
    contact breaking threshold in metres (default :data:`BEAD_CONTACT_BREAKING_M`; a skill's
    world takes its own from :func:`skill_world_config`).
    """

    time_step: float = 1.0 / 240.0
    solver_iterations: int = 5
    contact_breaking_threshold: float = BEAD_CONTACT_BREAKING_M
    gui: bool = False


def skill_world_config(skill: str, base: WorldConfig | None = None,
                       contact_breaking_m: Mapping[str, float] | None = None,
                       solver_iterations: int | None = None) -> WorldConfig:
    """``base`` (default :class:`WorldConfig`) with ``skill``'s contact breaking threshold,
    ``contact_breaking_m[skill]`` when given there (metres; a what-if for benchmarks), else
    :data:`SKILL_CONTACT_BREAKING_M`, and its solver iterations, ``solver_iterations`` when
    given (a what-if for every skill), else :data:`SKILL_SOLVER_ITERATIONS`. Raises
    ``KeyError`` for an unknown skill, ``ValueError`` for a setting out of range."""
    overrides = contact_breaking_m or {}
    threshold = overrides.get(skill, SKILL_CONTACT_BREAKING_M[skill])
    if not 0.0 < threshold <= 0.1:
        raise ValueError(f"contact breaking threshold of {skill!r} must be in (0, 0.1] m, "
                         f"got {threshold}")
    iterations = SKILL_SOLVER_ITERATIONS[skill] if solver_iterations is None else solver_iterations
    if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
        raise ValueError(f"solver iterations of {skill!r} must be an integer >= 1, "
                         f"got {iterations!r}")
    return replace(base or WorldConfig(), contact_breaking_threshold=float(threshold),
                   solver_iterations=iterations)


def physics_tag(skill: str, config: WorldConfig) -> str:
    """What trial records of ``skill`` simulated in a world of ``config`` carry as their
    physics (``TrialRecord.physics``): ``pybullet@v<physics_version(skill)>``, with
    ``+solver<n>`` / ``+breaking<m>m`` when ``config`` departs from the skill's shipped
    solver iterations / contact breaking threshold (a what-if's labels are not the shipped
    ones, so a file never mixes the two)."""
    shipped = skill_world_config(skill)
    tag = f"pybullet@v{physics_version(skill)}"
    if config.solver_iterations != shipped.solver_iterations:
        tag += f"+solver{config.solver_iterations}"
    if config.contact_breaking_threshold != shipped.contact_breaking_threshold:
        tag += f"+breaking{config.contact_breaking_threshold:g}m"
    return tag


class PhysicsWorld:
    """A PyBullet client with a table plane at ``z = 0``; reset between trials."""

    def __init__(self, config: WorldConfig | None = None) -> None:
        self.config = config or WorldConfig()
        #: The threshold (m) :meth:`step` sets; :meth:`contact_breaking` changes it for a while.
        self.contact_breaking_m = self.config.contact_breaking_threshold
        self.client = p.connect(p.GUI if self.config.gui else p.DIRECT)
        if self.client < 0:
            raise RuntimeError("could not connect to a PyBullet physics server")
        self.table: int = -1
        self.reset()

    def reset(self) -> None:
        """Remove every body and restore the settings (keeps the client: cheap and
        deterministic, unlike removing bodies one by one)."""
        p.resetSimulation(physicsClientId=self.client)
        p.setGravity(0.0, 0.0, -GRAVITY_M_S2, physicsClientId=self.client)
        p.setPhysicsEngineParameter(
            fixedTimeStep=self.config.time_step,
            numSolverIterations=self.config.solver_iterations,
            deterministicOverlappingPairs=1,
            contactBreakingThreshold=self.contact_breaking_m,
            physicsClientId=self.client,
        )
        plane = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=self.client)
        self.table = p.createMultiBody(0.0, plane, physicsClientId=self.client)
        p.changeDynamics(self.table, -1, lateralFriction=0.6, physicsClientId=self.client)

    def step(self, n: int = 1) -> None:
        """``n`` simulation steps, after setting this world's contact breaking threshold
        (process-global in Bullet, see the module docstring: another world may have set its
        own since this world's last step)."""
        p.setPhysicsEngineParameter(
            contactBreakingThreshold=self.contact_breaking_m,
            physicsClientId=self.client,
        )
        for _ in range(n):
            p.stepSimulation(physicsClientId=self.client)

    @contextmanager
    def contact_breaking(self, threshold_m: float) -> Iterator[None]:
        """Step with contact breaking threshold ``threshold_m`` (m) inside the block, e.g. for
        one action of a plan whose world otherwise keeps the bead piles' threshold."""
        previous, self.contact_breaking_m = self.contact_breaking_m, float(threshold_m)
        try:
            yield
        finally:
            self.contact_breaking_m = previous

    @contextmanager
    def skill_physics(self, config: WorldConfig) -> Iterator[None]:
        """Step with ``config``'s solver iterations and contact breaking threshold inside the
        block (a skill's trial settings, :func:`skill_world_config`, for one action of a plan
        whose world otherwise keeps its own); this world's settings are restored after.
        Raises ``ValueError`` if ``config``'s time step is not this world's (the step count
        of every motion depends on it)."""
        if config.time_step != self.config.time_step:
            raise ValueError(f"skill physics time step {config.time_step} s differs from the "
                             f"world's {self.config.time_step} s")
        self._set_solver_iterations(config.solver_iterations)
        try:
            with self.contact_breaking(config.contact_breaking_threshold):
                yield
        finally:
            self._set_solver_iterations(self.config.solver_iterations)

    def solver_iterations(self) -> int:
        """The solver iterations per step the client runs now (read back from PyBullet)."""
        params = p.getPhysicsEngineParameters(physicsClientId=self.client)
        return int(params["numSolverIterations"])

    def _set_solver_iterations(self, iterations: int) -> None:
        # Per client, unlike the contact breaking threshold: no need to re-set it per step.
        p.setPhysicsEngineParameter(numSolverIterations=int(iterations),
                                    physicsClientId=self.client)

    def steps_for(self, seconds: float) -> int:
        """Number of simulation steps covering ``seconds`` of simulated time."""
        return max(1, round(seconds / self.config.time_step))

    def close(self) -> None:
        if self.client >= 0:
            p.disconnect(physicsClientId=self.client)
            self.client = -1

    def __enter__(self) -> PhysicsWorld:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()
