"""Python bindings of the kitchen2d streams (Box2D Kitchen2D geometry + learned skills).

The scene (object sizes and their homes along the table) is drawn from ``world`` with the
planner's stream RNG *before anything else*, so the executor rebuilds the same arrangement
from the same seed (:func:`ltamp_cli.backends.box2d.scene.scene_from_world`). Initial poses
are symbolic PDDL objects and mean "the object's home".

GoodPour and GoodScoop are learned: the GP level-set models (``world.models``, paths
relative to this folder) are loaded once per planning run; for a context the stream yields
the most confident control ``θ* = argmax μ/σ`` first, then further controls with
``μ/σ > β`` (the relaxed threshold ``β = Φ⁻¹(λ Φ(φ(θ*)))``), all of them passing the skill's
start-collision test and the kitchen's checks (approach, swing, the pour must not touch the
target cup: the pour score does not penalise shoving it aside, a plan must). Values are documented
in :mod:`ltamp_cli.backends.box2d.tamp`.

**Physics pre-check** (opt-in, ``world.precheck: [pour, scoop]``): before a learned control is
yielded it is also run once as the skill's own Box2D trial (the simulation the model was learned
from, with the scene's cup sizes, trial seed 0, about 0.3–0.6 s of CPU for a pour) and dropped
unless it scores > 0. The paper's planner trusts the model; this trades planning time for
fewer failed executions. At most ``world.precheck_limit`` (default 8) trials are run per
stream call; a control within half a lengthscale (the model's) of one that failed is refused
without a trial. Every check is logged on the ``ltamp.kitchen2d`` logger (INFO, with the record
attribute ``precheck``: skill, score, verdict) so that callers can report how many controls
the pre-check rejected.

GoodPush (``sample-push``) is a generic :class:`~ltamp_cli.learned_streams.stream.LearnedStream`
over the push model (``world.learned_streams.sample-push`` or the shipped
``models/kitchen2d/push``): its context is the goal ``(goal_x, 0)`` a little past the table
edge, its samples are restricted to the kitchen's section (pushes in line with the block,
:func:`~ltamp_cli.backends.box2d.tamp.section_mask`) and the planner's "unusable" feedback
goes back to its sampler.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.backends.box2d.scene import default_grasp, scene_from_world
from ltamp_cli.backends.box2d.skills import pour as pour_skill
from ltamp_cli.backends.box2d.skills import push as push_skill
from ltamp_cli.backends.box2d.skills import scoop as scoop_skill
from ltamp_cli.backends.box2d.tamp import KitchenGeometry, Point, section_mask
from ltamp_cli.errors import InputError
from ltamp_cli.learned_streams.stream import (
    LearnedStream,
    LearnedStreamConfig,
    learned_stream_configs,
)
from ltamp_cli.planner.streams import Binding, StreamInfo

HERE = Path(__file__).resolve().parent
LOG = logging.getLogger("ltamp.kitchen2d")
PRECHECK_SKILLS = ("pour", "scoop")
#: Pre-check: controls within this many lengthscales of a failed one are not simulated.
NEAR_FAILURE = 0.5
DEFAULT_MODELS = {"pour": "../../models/kitchen2d/pour", "scoop": "../../models/kitchen2d/scoop"}
DEFAULT_PUSH = {"model": "../../models/kitchen2d/push", "sampler": "adaptive"}
#: GoodPush gives up on one (block, pose, edge) after this many controls in a row that the
#: kitchen cannot use (the sampler itself never ends while its level set has members).
PUSH_REJECTS = 200


class _GiveUp(Exception):
    """Raised inside a learned stream's output mapping to end that stream call."""


def push_stream(world: Mapping[str, Any], geometry: KitchenGeometry,
                rng: np.random.Generator) -> tuple[LearnedStream, Callable[..., Any]]:
    """GoodPush and the planner generator over it (inputs ``(block, pose, edge)``, outputs
    ``(conf, approach, control)``). The model is loaded once, never refitted."""
    configs = learned_stream_configs(world, HERE)
    config = configs.get("sample-push") or LearnedStreamConfig.from_mapping(
        DEFAULT_PUSH, HERE, "sample-push")
    if not (config.model_dir / "model.json").is_file():
        raise InputError(f"world: learned_streams.sample-push.model: no model directory at "
                         f"{config.model_dir}")
    push_config = push_skill.PushConfig()
    rejected: dict[tuple[Any, ...], int] = {}  # per stream call (inputs)

    def context(block: str, pose: Any, edge: str) -> np.ndarray:
        found = geometry.push_context(block, _pose(geometry, block, pose), edge)
        assert found is not None  # the generator below checks reach first
        return found

    def outputs(control: np.ndarray, block: str, pose: Any, edge: str
                ) -> tuple[Any, ...] | None:
        setup = geometry.push_setup(block, _pose(geometry, block, pose), edge, control)
        key = (block, str(pose), edge)
        if setup is None:
            rejected[key] = rejected.get(key, 0) + 1
            if rejected[key] >= PUSH_REJECTS:
                raise _GiveUp
            return None
        rejected[key] = 0
        conf, approach = setup
        return (conf, approach, _tuple(control))

    def valid(ctx: np.ndarray, controls: np.ndarray) -> np.ndarray:
        return push_skill.valid_mask(ctx, controls, push_config) & section_mask(ctx, controls)

    stream = LearnedStream(config, context, outputs, rng, valid)

    def generate(block: str, pose: Any, edge: str) -> Iterator[tuple[Any, ...]]:
        item = geometry.spec.object(block)
        if item.kind != "block":
            return
        p = _pose(geometry, block, pose)
        try:
            geometry.edge_x(edge)
        except ValueError as error:
            raise InputError(f"sample-push: {error}") from None
        # The block must reach the edge without meeting a curb, and the goal past the edge
        # must lie in the skill's context box: otherwise no control can help.
        if geometry.push_context(block, p, edge) is None or not geometry.push_path_clear(
                block, p, edge):
            return
        rejected[(block, str(pose), edge)] = 0
        try:
            yield from stream(block, pose, edge)
        except _GiveUp:
            return

    return stream, generate


class LearnedControls:
    """Confident controls of one learned skill for a context and a placement.

    ``valid(context, controls (n, d)) -> (n,) bool`` is the skill's start-collision test
    (vectorised); ``feasible(control) -> bool``, given per query, is the kitchen's own check
    (approach and swing clear of everything else). ``θ*`` is the most confident control
    among ``n`` random valid *and feasible* controls; later ones are the other candidates
    with ``μ/σ > β``, ``β = Φ⁻¹(λ Φ(μ/σ(θ*)))``, most confident first. Each batch of
    candidates is predicted in one vectorised GP call; the model is never refitted.
    """

    def __init__(self, model_dir: Path, valid: Callable[[np.ndarray, np.ndarray], np.ndarray],
                 rng: np.random.Generator, lam: float = 0.95, batch: int = 4000) -> None:
        from ltamp_cli.learning.model import LevelSetModel

        self.model = LevelSetModel.load(str(model_dir))
        self.valid = valid
        self.rng = rng
        self.lam = lam
        self.batch = batch

    def control_scale(self) -> np.ndarray:
        """The GP's ARD lengthscales of the controls in physical units, ``(dθ,)``."""
        space = self.model.spec.control
        width = np.asarray(space.highs, dtype=float) - np.asarray(space.lows, dtype=float)
        return np.asarray(self.model.lengthscales, dtype=float)[: space.dim] * width / 2.0

    def controls(self, context: np.ndarray, feasible: Callable[[np.ndarray], bool],
                 rounds: int = 5) -> Iterator[np.ndarray]:
        from ltamp_cli.learning.confidence import relaxed_beta

        beta: float | None = None
        space = self.model.spec.control
        for _ in range(rounds):
            candidates = space.sample_uniform(self.rng, self.batch)
            candidates = candidates[self.valid(context, candidates)]
            if len(candidates) == 0:
                continue
            mean, std = self.model.predict(np.repeat(context[None, :], len(candidates), 0),
                                           candidates)
            phi = mean / std
            order = np.argsort(-phi)
            for index in order:
                if beta is not None and phi[index] <= beta:
                    break
                if not feasible(candidates[index]):
                    continue
                if beta is None:
                    beta = relaxed_beta(float(phi[index]), self.lam)
                yield candidates[index]


class SkillCheck:
    """The opt-in physics pre-check of a learned skill's controls (see the module docstring).

    ``module`` is the skill module (``run(context (dα,), control (dθ,), seed, config)``);
    ``limit`` bounds the trials per stream call (:meth:`budget` starts a call's count);
    ``checked``/``rejected`` count every trial this check ran, ``skipped`` the controls
    refused without a trial for being next to a failed one.
    """

    def __init__(self, skill: str, module: Any, config: Any, limit: int) -> None:
        self.skill = skill
        self.module = module
        self.config = config
        self.limit = limit
        self.checked = 0
        self.rejected = 0
        self.skipped = 0

    def budget(self, scale: np.ndarray | None = None) -> Callable[[np.ndarray, np.ndarray], bool]:
        """The check of one stream call, ``passes(context, control) -> bool``: at most
        ``limit`` simulations, later controls are refused without simulating.

        With ``scale`` (the model's control lengthscales, physical units) a control closer
        than ``NEAR_FAILURE`` lengthscales to one that already failed its trial is refused
        without simulating: the model sees the two as one (correlation > 0.8 for Matérn-5/2),
        and the most confident candidates often crowd into one such spot.
        """
        left = [self.limit]
        failed: list[np.ndarray] = []

        def passes(context: np.ndarray, control: np.ndarray) -> bool:
            if left[0] <= 0:
                return False
            if scale is not None and any(
                    float(np.linalg.norm((control - bad) / scale)) < NEAR_FAILURE
                    for bad in failed):
                self.skipped += 1
                return False
            left[0] -= 1
            result = self.module.run(context, control, 0, self.config)
            ok = bool(result.valid and result.score > 0.0)
            self.checked += 1
            self.rejected += not ok
            if not ok:
                failed.append(np.asarray(control, dtype=float))
            LOG.info("precheck %s: context=%s control=%s score=%.3f %s", self.skill,
                     _tuple(context), _tuple(control), result.score,
                     "accepted" if ok else "rejected",
                     extra={"precheck": {"skill": self.skill, "score": float(result.score),
                                         "accepted": ok}})
            return ok

        return passes


def _prechecks(world: Mapping[str, Any], configs: Mapping[str, Any]) -> dict[str, SkillCheck]:
    """The ``world.precheck`` skills' checks (none by default)."""
    raw = world.get("precheck", []) or []
    if not isinstance(raw, list) or any(s not in PRECHECK_SKILLS for s in raw):
        raise InputError(f"world: precheck: expected a list of skills among "
                         f"{', '.join(PRECHECK_SKILLS)}, got {raw!r}")
    limit = world.get("precheck_limit", 8)
    if isinstance(limit, bool) or not isinstance(limit, int) or limit < 1:
        raise InputError(f"world: precheck_limit: expected an integer >= 1, got {limit!r}")
    modules = {"pour": pour_skill, "scoop": scoop_skill}
    return {skill: SkillCheck(skill, modules[skill], configs[skill], limit) for skill in raw}


def _pose(geometry: KitchenGeometry, name: str, pose: Any) -> Point:
    if isinstance(pose, str):
        return (round(geometry.spec.object(name).home, 4), round(geometry.top, 4))
    return (float(pose[0]), float(pose[1]))


def _tuple(values: np.ndarray) -> tuple[float, ...]:
    return tuple(round(float(v), 6) for v in values)


def make_streams(world: Mapping[str, Any], rng: np.random.Generator) -> dict[str, Any]:
    scene = scene_from_world(world, rng)  # first draws: the executor repeats them
    geometry = KitchenGeometry(scene, motion_time=float(world.get("motion_time", 1.0)))
    models = {**DEFAULT_MODELS, **dict(world.get("models", {}) or {})}
    learned: dict[str, LearnedControls] = {}
    pour_config, scoop_config = pour_skill.PourConfig(), scoop_skill.ScoopConfig()
    prechecks = _prechecks(world, {"pour": pour_config, "scoop": scoop_config})

    def model(skill: str) -> LearnedControls:
        if skill not in learned:
            path = (HERE / str(models[skill])).resolve()
            if not (path / "model.json").is_file():
                raise InputError(f"world: models.{skill}: no model directory at {path}")
            module, config = (pour_skill, pour_config) if skill == "pour" else (
                scoop_skill, scoop_config)
            learned[skill] = LearnedControls(
                path, lambda c, u, m=module, k=config: m.valid_mask(c, u, k), rng)
        return learned[skill]

    def sample_placement(name: str, region: str) -> Iterator[tuple[Point]]:
        for pose in geometry.placements(name, region):
            yield (pose,)

    def sample_grasp(name: str) -> tuple[Point]:
        return (default_grasp(scene.object(name)),)

    def inverse_kinematics(name: str, pose: Any, grasp: Point) -> tuple[Any, ...] | None:
        found = geometry.kinematics(name, _pose(geometry, name, pose), tuple(grasp))
        return None if found is None else found

    def plan_free_motion(q1: Point, q2: Point) -> tuple[Any] | None:
        if q1 == q2:
            return None
        path = geometry.plan_motion(tuple(q1), tuple(q2))
        return None if path is None else (path,)

    def plan_holding_motion(name: str, grasp: Point, q1: Point, q2: Point
                            ) -> tuple[Any] | None:
        if q1 == q2:
            return None
        path = geometry.plan_motion(tuple(q1), tuple(q2), name, tuple(grasp))
        return None if path is None else (path,)

    def sample_pour(source: str, target: str, pose: Any, region: str
                    ) -> Iterator[tuple[Any, ...]]:
        src, dst = scene.object(source), scene.object(target)
        if source == target or not src.material:
            return
        p = _pose(geometry, target, pose)
        context = np.array([src.spec.width, src.spec.height, dst.spec.width, dst.spec.height])
        setups: dict[bytes, Any] = {}
        check = (prechecks["pour"].budget(model("pour").control_scale())
                 if "pour" in prechecks else None)

        def feasible(control: np.ndarray) -> bool:
            setups[control.tobytes()] = geometry.pour_setup(source, target, p, control)
            if setups[control.tobytes()] is None:
                return False
            return check is None or check(context, control)

        for control in model("pour").controls(context, feasible):
            grasp, conf, approach = setups[control.tobytes()]
            yield (grasp, conf, approach, _tuple(control))

    def sample_scoop(spoon: str, bowl: str, pose: Any) -> Iterator[tuple[Any, ...]]:
        cup = scene.object(bowl)
        if not cup.material:
            return
        p = _pose(geometry, bowl, pose)
        context = np.array([cup.spec.width, cup.spec.height])
        setups: dict[bytes, Any] = {}
        check = (prechecks["scoop"].budget(model("scoop").control_scale())
                 if "scoop" in prechecks else None)

        def feasible(control: np.ndarray) -> bool:
            setups[control.tobytes()] = geometry.scoop_setup(spoon, bowl, p, control)
            if setups[control.tobytes()] is None:
                return False
            return check is None or check(context, control)

        for control in model("scoop").controls(context, feasible):
            grasp, conf, approach = setups[control.tobytes()]
            yield (grasp, conf, approach, _tuple(control))

    push, sample_push = push_stream(world, geometry, rng) if any(
        o.kind == "block" for o in scene.objects) else (None, None)

    def sample_dump(spoon: str, grasp: Point, target: str, pose: Any, region: str
                    ) -> Iterator[tuple[Any, ...]]:
        p = _pose(geometry, target, pose)
        yield from geometry.dump_setups(spoon, tuple(grasp), target, p)

    def sample_stir(stirrer: str, grasp: Point, target: str, pose: Any, region: str
                    ) -> tuple[Any, ...] | None:
        p = _pose(geometry, target, pose)
        return geometry.stir_setup(stirrer, tuple(grasp), target, p)

    def test_cfree(a: str, pa: Any, b: str, pb: Any) -> bool:
        return geometry.cfree(a, _pose(geometry, a, pa), b, _pose(geometry, b, pb))

    def distance(q1: Point, q2: Point) -> float:
        return geometry.distance(tuple(q1), tuple(q2))

    cheap = StreamInfo(overhead=0.01)
    bindings: dict[str, Any] = {}
    if push is not None:
        bindings["sample-push"] = Binding(sample_push, StreamInfo(p_success=0.8, overhead=0.5),
                                          on_unusable=push.on_unusable)
    else:
        bindings["sample-push"] = lambda block, pose, edge: iter(())
    return bindings | {
        "sample-placement": Binding(sample_placement, cheap),
        "sample-grasp": Binding(sample_grasp, cheap),
        "inverse-kinematics": Binding(inverse_kinematics, cheap),
        "plan-free-motion": Binding(plan_free_motion, StreamInfo(overhead=0.05)),
        "plan-holding-motion": Binding(plan_holding_motion, StreamInfo(overhead=0.05)),
        "sample-pour": Binding(sample_pour, StreamInfo(p_success=0.8, overhead=0.5)),
        "sample-scoop": Binding(sample_scoop, StreamInfo(p_success=0.8, overhead=0.5)),
        "sample-dump": Binding(sample_dump, cheap),
        "sample-stir": Binding(sample_stir, cheap),
        "test-cfree": Binding(test_cfree, StreamInfo(eager=True, overhead=0.001)),
        "distance": distance,
        "holddistance": lambda name, grasp, q1, q2: distance(q1, q2),
    }
