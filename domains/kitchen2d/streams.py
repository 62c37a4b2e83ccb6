"""Python bindings of the kitchen2d streams (Box2D Kitchen2D geometry + learned skills).

The scene (object sizes and their homes along the table) is drawn from ``world`` with the
planner's stream RNG *before anything else*, so the executor rebuilds the same arrangement
from the same seed (:func:`ltamp_cli.backends.box2d.scene.scene_from_world`). Initial poses
are symbolic PDDL objects and mean "the object's home".

GoodPour, GoodScoop and GoodPush are learned streams
(:class:`~ltamp_cli.learned_streams.kitchen.GoodPour`, ``GoodScoop``, a generic
:class:`~ltamp_cli.learned_streams.stream.LearnedStream`): each draws controls of a GP level-set
model (loaded once per planning run, never refitted) from the sampler its problem chooses::

    world:
      learned_streams:
        sample-pour: {model: ../../models/kitchen2d/pour, sampler: diverse-lk}
        sample-scoop: {model: ../../models/kitchen2d/scoop, sampler: adaptive}
        sample-push: {model: ../../models/kitchen2d/push, sampler: rejection}

(paths relative to this folder; :data:`LEARNED_STREAMS` gives the defaults, and
``world.models.<skill>`` still names a model alone). The kitchen's hard tests run *inside*
the sampler, vectorised over its candidate batches (:mod:`ltamp_cli.backends.box2d.tamp_batch`):
the skill's start-collision test and the kitchen's approach and swing checks, for a pour also
"the tilt must not graze the target cup" (the pour score does not penalise shoving the target
aside, a plan must), for a push the kitchen's section (pushes in line with the block). So the
set's θ*, β and proposals are those of valid controls. The planner's "unusable downstream"
feedback reaches the sampler (``diverse-lk`` learns its kernel from it). Values are
documented in :mod:`ltamp_cli.backends.box2d.tamp`.

**Physics pre-check** (opt-in, ``world.precheck: [pour, scoop]``): before a learned control is
yielded it is also run once as the skill's own Box2D trial (the simulation the model was learned
from, with the scene's cup sizes, trial seed 0, about 0.3–0.6 s of CPU for a pour) and dropped
unless it scores > 0. The paper's planner trusts the model; this trades planning time for
fewer failed executions. At most ``world.precheck_limit`` (default 8) trials are run per
stream call (the call then ends); a control within half a lengthscale (the model's) of one
that failed is refused without a trial. Every check is logged on the ``ltamp.kitchen2d``
logger (INFO, with the record attribute ``precheck``: skill, score, verdict) so that callers
can report how many controls the pre-check rejected.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Collection, Iterator, Mapping
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.backends.box2d.scene import default_grasp, scene_from_world
from ltamp_cli.backends.box2d.skills import pour as pour_skill
from ltamp_cli.backends.box2d.skills import push as push_skill
from ltamp_cli.backends.box2d.skills import scoop as scoop_skill
from ltamp_cli.backends.box2d.tamp import KitchenGeometry, Point, section_mask
from ltamp_cli.backends.box2d.tamp_batch import pour_mask, push_mask, scoop_mask
from ltamp_cli.errors import InputError
from ltamp_cli.learned_streams.kitchen import PUSH_NAMES, GoodPour, GoodScoop
from ltamp_cli.learned_streams.stream import (
    LearnedStream,
    LearnedStreamConfig,
    ModelCache,
    learned_stream_configs,
)
from ltamp_cli.planner.keyed_random import KeyedRandom
from ltamp_cli.planner.streams import Binding, StreamInfo

HERE = Path(__file__).resolve().parent
LOG = logging.getLogger("ltamp.kitchen2d")
PRECHECK_SKILLS = ("pour", "scoop")
#: Pre-check: controls within this many lengthscales of a failed one are not simulated.
NEAR_FAILURE = 0.5
#: The kitchen's learned streams: skill, default model (relative to this folder) and sampler.
#: Pour and scoop default to ``diverse``: its first control is θ*, the most confident valid
#: one (what the kitchen drew first before it had a sampler choice), the next ones spread
#: over the confident set.
LEARNED_STREAMS = {
    "sample-pour": ("pour", "../../models/kitchen2d/pour", "diverse"),
    "sample-scoop": ("scoop", "../../models/kitchen2d/scoop", "diverse"),
    "sample-push": ("push", "../../models/kitchen2d/push", "adaptive"),
}
#: A learned stream call ends after this many controls in a row that the kitchen cannot use
#: (the samplers never end while their set has members; the hard tests run inside them, so
#: only the physics pre-check or a rounding edge rejects a control afterwards).
MAX_REJECTS = 200
PUSH_REJECTS = MAX_REJECTS  # the name earlier versions used


class _GiveUp(Exception):
    """Raised inside a learned stream's output mapping to end that stream call."""


def learned_configs(world: Mapping[str, Any], needed: Collection[str] = tuple(LEARNED_STREAMS)
                    ) -> dict[str, LearnedStreamConfig]:
    """Model and sampler of each learned stream: ``world.learned_streams.<stream>`` if given
    (paths relative to this folder), else ``world.models.<skill>`` (the older form, model
    only) or the shipped model, with the stream's default sampler. The model directories of
    the ``needed`` streams must exist."""
    configs = learned_stream_configs(world, HERE)
    unknown = sorted(set(configs) - set(LEARNED_STREAMS))
    if unknown:
        raise InputError(f"world.learned_streams.{unknown[0]}: not a learned stream of the "
                         f"kitchen2d domain: expected one of {', '.join(LEARNED_STREAMS)}")
    models = dict(world.get("models", {}) or {})
    for name, (skill, default, sampler) in LEARNED_STREAMS.items():
        if name in configs:
            if skill in models:
                raise InputError(f"world.models.{skill}: the model of {name} is also given in "
                                 f"world.learned_streams.{name}: keep one")
            where = f"world.learned_streams.{name}.model"
        else:
            model = models.get(skill, default)
            if not isinstance(model, str):
                raise InputError(f"world.models.{skill}: expected the path of a model directory")
            configs[name] = LearnedStreamConfig.from_mapping(
                {"model": model, "sampler": sampler}, HERE, name)
            where = f"world.models.{skill}" if skill in models else name
        if name in needed and not (configs[name].model_dir / "model.json").is_file():
            raise InputError(f"{where}: no model directory at {configs[name].model_dir}")
    return configs


class KitchenLearnedStream:
    """A learned stream of the kitchen wired for the planner: ``generate(*inputs)`` checks
    the inputs (``applies``), then draws from ``stream``; a call ends after
    :data:`MAX_REJECTS` unusable controls in a row or when ``outputs`` raises ``_GiveUp``.
    ``on_unusable`` is the planner feedback (routed to the call's sampler)."""

    def __init__(self, stream: LearnedStream, applies: Callable[..., bool]) -> None:
        self.stream = stream
        self.applies = applies
        self.rejected: dict[tuple[str, ...], int] = {}  # per stream call (inputs)

    def reject(self, inputs: tuple[Any, ...]) -> None:
        """Count one unusable control of the call ``inputs`` (ends it after too many)."""
        key = tuple(map(str, inputs))
        self.rejected[key] = self.rejected.get(key, 0) + 1
        if self.rejected[key] >= MAX_REJECTS:
            raise _GiveUp

    def accept(self, inputs: tuple[Any, ...]) -> None:
        self.rejected[tuple(map(str, inputs))] = 0

    def generate(self, *inputs: Any) -> Iterator[tuple[Any, ...]]:
        if not self.applies(*inputs):
            return
        self.accept(inputs)
        try:
            yield from self.stream(*inputs)
        except _GiveUp:
            return

    def binding(self, info: StreamInfo) -> Binding:
        return Binding(self.generate, info, on_unusable=self.stream.on_unusable)


def _held_tool_outputs(wired: KitchenLearnedStream, inputs: tuple[Any, ...], setup: Any,
                       control: np.ndarray, budgets: Mapping[tuple[str, ...], Budget],
                       context: Callable[..., np.ndarray]) -> tuple[Any, ...] | None:
    """Pour/scoop outputs ``(grasp, conf, approach, control)`` of a control whose kitchen
    ``setup`` exists and that passes the call's physics pre-check budget (if any); otherwise
    the control counts as rejected and ``None`` is returned (the call ends once the budget
    is spent)."""
    budget = budgets.get(tuple(map(str, inputs)))
    if setup is None or (budget is not None and not budget(
            context(*inputs), np.asarray(control, dtype=float))):
        if budget is not None and budget.spent:
            raise _GiveUp
        wired.reject(inputs)
        return None
    wired.accept(inputs)
    grasp, conf, approach = setup
    return (grasp, conf, approach, _tuple(control))


def control_scale(stream: LearnedStream) -> np.ndarray:
    """The GP's ARD lengthscales of the controls in physical units, ``(dθ,)``."""
    space = stream.model.spec.control
    width = np.asarray(space.highs, dtype=float) - np.asarray(space.lows, dtype=float)
    return np.asarray(stream.model.lengthscales, dtype=float)[: space.dim] * width / 2.0


def pour_stream(config: LearnedStreamConfig, geometry: KitchenGeometry,
                keyed: KeyedRandom, check: SkillCheck | None,
                models: ModelCache) -> KitchenLearnedStream:
    """GoodPour over the kitchen: inputs ``(source, target, pose, region)``, outputs
    ``(grasp, conf, approach, control)``. Hard tests inside the sampler: the pour skill's
    start-collision test and the kitchen's approach, swing and "the tilt must not graze the
    target" tests (:func:`~ltamp_cli.backends.box2d.tamp_batch.pour_mask`)."""
    scene = geometry.spec
    skill_config = pour_skill.PourConfig()
    budgets: dict[tuple[str, ...], Budget] = {}

    def context(source: str, target: str, pose: Any, region: str) -> np.ndarray:
        src, dst = scene.object(source).spec, scene.object(target).spec
        return np.array([src.width, src.height, dst.width, dst.height], dtype=float)

    def validity_for(source: str, target: str, pose: Any, region: str) -> Any:
        p = _pose(geometry, target, pose)

        def valid(ctx: np.ndarray, controls: np.ndarray) -> np.ndarray:
            ok = pour_skill.valid_mask(ctx, controls, skill_config)
            if ok.any():
                ok[ok] = pour_mask(geometry, source, target, p, controls[ok])
            return ok

        return valid

    def outputs(control: np.ndarray, source: str, target: str, pose: Any, region: str
                ) -> tuple[Any, ...] | None:
        inputs = (source, target, pose, region)
        setup = geometry.pour_setup(source, target, _pose(geometry, target, pose), control)
        return _held_tool_outputs(wired, inputs, setup, control, budgets, context)

    def applies(source: str, target: str, pose: Any, region: str) -> bool:
        if source == target or not scene.object(source).material:
            return False
        if check is not None:
            budgets[(source, target, str(pose), region)] = check.budget(control_scale(stream))
        return True

    stream = GoodPour(config, keyed("sample-pour"), outputs, models=models,
                      to_context=context, validity_for=validity_for,
                      rng_for=partial(keyed, "sample-pour"))
    wired = KitchenLearnedStream(stream, applies)
    return wired


def scoop_stream(config: LearnedStreamConfig, geometry: KitchenGeometry,
                 keyed: KeyedRandom, check: SkillCheck | None,
                 models: ModelCache) -> KitchenLearnedStream:
    """GoodScoop over the kitchen: inputs ``(spoon, bowl, pose)``, outputs ``(grasp, conf,
    approach, control)``; hard tests inside the sampler: the skill's swept-path test and the
    kitchen's approach and exit (:func:`~ltamp_cli.backends.box2d.tamp_batch.scoop_mask`)."""
    scene = geometry.spec
    skill_config = scoop_skill.ScoopConfig()
    budgets: dict[tuple[str, ...], Budget] = {}

    def context(spoon: str, bowl: str, pose: Any) -> np.ndarray:
        cup = scene.object(bowl).spec
        return np.array([cup.width, cup.height], dtype=float)

    def validity_for(spoon: str, bowl: str, pose: Any) -> Any:
        p = _pose(geometry, bowl, pose)

        def valid(ctx: np.ndarray, controls: np.ndarray) -> np.ndarray:
            ok = scoop_skill.valid_mask(ctx, controls, skill_config)
            if ok.any():
                ok[ok] = scoop_mask(geometry, spoon, bowl, p, controls[ok])
            return ok

        return valid

    def outputs(control: np.ndarray, spoon: str, bowl: str, pose: Any
                ) -> tuple[Any, ...] | None:
        inputs = (spoon, bowl, pose)
        setup = geometry.scoop_setup(spoon, bowl, _pose(geometry, bowl, pose), control)
        return _held_tool_outputs(wired, inputs, setup, control, budgets, context)

    def applies(spoon: str, bowl: str, pose: Any) -> bool:
        if not scene.object(bowl).material:
            return False
        if check is not None:
            budgets[(spoon, bowl, str(pose))] = check.budget(control_scale(stream))
        return True

    stream = GoodScoop(config, keyed("sample-scoop"), outputs, models=models,
                       to_context=context, validity_for=validity_for,
                       rng_for=partial(keyed, "sample-scoop"))
    wired = KitchenLearnedStream(stream, applies)
    return wired


def push_stream(config: LearnedStreamConfig, geometry: KitchenGeometry,
                keyed: KeyedRandom, models: ModelCache) -> KitchenLearnedStream:
    """GoodPush: inputs ``(block, pose, edge)``, outputs ``(conf, approach, control)``; hard
    tests inside the sampler: the skill's start test, the kitchen's section (pushes in line
    with the block) and the pusher's path (:func:`~ltamp_cli.backends.box2d.tamp_batch.
    push_mask`). The model is loaded once, never refitted."""
    push_config = push_skill.PushConfig()

    def context(block: str, pose: Any, edge: str) -> np.ndarray:
        found = geometry.push_context(block, _pose(geometry, block, pose), edge)
        assert found is not None  # ``applies`` checks reach first
        return found

    def validity_for(block: str, pose: Any, edge: str) -> Any:
        p = _pose(geometry, block, pose)

        def valid(ctx: np.ndarray, controls: np.ndarray) -> np.ndarray:
            ok = push_skill.valid_mask(ctx, controls, push_config) & section_mask(ctx, controls)
            if ok.any():
                ok[ok] = push_mask(geometry, block, p, edge, controls[ok])
            return ok

        return valid

    def outputs(control: np.ndarray, block: str, pose: Any, edge: str
                ) -> tuple[Any, ...] | None:
        setup = geometry.push_setup(block, _pose(geometry, block, pose), edge, control)
        if setup is None:
            wired.reject((block, pose, edge))
            return None
        wired.accept((block, pose, edge))
        conf, approach = setup
        return (conf, approach, _tuple(control))

    def applies(block: str, pose: Any, edge: str) -> bool:
        if geometry.spec.object(block).kind != "block":
            return False
        p = _pose(geometry, block, pose)
        try:
            geometry.edge_x(edge)
        except ValueError as error:
            raise InputError(f"sample-push: {error}") from None
        # The block must reach the edge without meeting a curb, and the goal past the edge
        # must lie in the skill's context box: otherwise no control can help.
        return geometry.push_context(block, p, edge) is not None and geometry.push_path_clear(
            block, p, edge)

    stream = LearnedStream(config, context, outputs, keyed("sample-push"), models=models,
                           validity_for=validity_for, context_names=PUSH_NAMES[0],
                           control_names=PUSH_NAMES[1],
                           rng_for=partial(keyed, "sample-push"))
    wired = KitchenLearnedStream(stream, applies)
    return wired


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

    def budget(self, scale: np.ndarray | None = None) -> Budget:
        """The check of one stream call, ``passes(context, control) -> bool``: at most
        ``limit`` simulations, later controls are refused without simulating
        (:attr:`Budget.spent` then tells the stream call to end).

        With ``scale`` (the model's control lengthscales, physical units) a control closer
        than ``NEAR_FAILURE`` lengthscales to one that already failed its trial is refused
        without simulating: the model sees the two as one (correlation > 0.8 for Matérn-5/2),
        and the most confident candidates often crowd into one such spot.
        """
        return Budget(self, scale)


class Budget:
    """One stream call's share of a :class:`SkillCheck` (see :meth:`SkillCheck.budget`)."""

    def __init__(self, check: SkillCheck, scale: np.ndarray | None) -> None:
        self.check = check
        self.scale = scale
        self.left = check.limit
        self.failed: list[np.ndarray] = []

    @property
    def spent(self) -> bool:
        """Whether every simulation of this call's budget has been used."""
        return self.left <= 0

    def __call__(self, context: np.ndarray, control: np.ndarray) -> bool:
        check = self.check
        if self.spent:
            return False
        if self.scale is not None and any(
                float(np.linalg.norm((control - bad) / self.scale)) < NEAR_FAILURE
                for bad in self.failed):
            check.skipped += 1
            return False
        self.left -= 1
        result = check.module.run(context, control, 0, check.config)
        ok = bool(result.valid and result.score > 0.0)
        check.checked += 1
        check.rejected += not ok
        if not ok:
            self.failed.append(np.asarray(control, dtype=float))
        LOG.info("precheck %s: context=%s control=%s score=%.3f %s", check.skill,
                 _tuple(context), _tuple(control), result.score,
                 "accepted" if ok else "rejected",
                 extra={"precheck": {"skill": check.skill, "score": float(result.score),
                                     "accepted": ok}})
        return ok


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
    # The learned streams draw per input tuple (KeyedRandom): one skill's samples do not
    # depend on how many controls the others drew (a new pour model leaves the scoops as
    # they were, so two models compare seed by seed).
    keyed = KeyedRandom(rng)
    geometry = KitchenGeometry(scene, motion_time=float(world.get("motion_time", 1.0)))
    # A learned stream is built (its model loaded) only if the scene has something it can act
    # on: a cup holding a material to pour, a spoon and a bowl or cup of material, a block.
    poured = any(o.kind == "cup" and o.material for o in scene.objects)
    scooped = any(o.kind == "spoon" for o in scene.objects) and any(
        o.kind in ("cup", "bowl") and o.material for o in scene.objects)
    pushed = any(o.kind == "block" for o in scene.objects)
    needed = {name for name, flag in (("sample-pour", poured), ("sample-scoop", scooped),
                                      ("sample-push", pushed)) if flag}
    configs = learned_configs(world, needed)
    pour_config, scoop_config = pour_skill.PourConfig(), scoop_skill.ScoopConfig()
    prechecks = _prechecks(world, {"pour": pour_config, "scoop": scoop_config})
    # Each model directory is loaded once per planning run, when its stream is first built.
    models = ModelCache()
    learned: dict[str, KitchenLearnedStream] = {}

    def learned_stream(name: str) -> KitchenLearnedStream:
        if name not in learned:
            if name == "sample-pour":
                learned[name] = pour_stream(configs[name], geometry, keyed,
                                            prechecks.get("pour"), models)
            elif name == "sample-scoop":
                learned[name] = scoop_stream(configs[name], geometry, keyed,
                                             prechecks.get("scoop"), models)
            else:
                learned[name] = push_stream(configs[name], geometry, keyed, models)
        return learned[name]

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
    skill = StreamInfo(p_success=0.8, overhead=0.5)
    bindings: dict[str, Any] = {
        name: learned_stream(name).binding(skill) if name in needed else (
            lambda *inputs: iter(()))
        for name in LEARNED_STREAMS
    }
    return bindings | {
        "sample-placement": Binding(sample_placement, cheap),
        "sample-grasp": Binding(sample_grasp, cheap),
        "inverse-kinematics": Binding(inverse_kinematics, cheap),
        "plan-free-motion": Binding(plan_free_motion, StreamInfo(overhead=0.05)),
        "plan-holding-motion": Binding(plan_holding_motion, StreamInfo(overhead=0.05)),
        "sample-dump": Binding(sample_dump, cheap),
        "sample-stir": Binding(sample_stir, cheap),
        "test-cfree": Binding(test_cfree, StreamInfo(eager=True, overhead=0.001)),
        "distance": distance,
        "holddistance": lambda name, grasp, q1, q2: distance(q1, q2),
    }
