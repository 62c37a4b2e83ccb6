"""Python bindings of the kitchen3d streams (PyBullet Kitchen3D geometry + GoodPour/GoodScoop).

The scene's shapes come from ``world`` (:mod:`ltamp_cli.backends.pybullet.tamp.scene`);
movable objects' poses are planner values ``(x, y)``; arms are planner objects whose value
is the arm index (``r0: 0``). One headless PyBullet world per planning run answers IK,
motion and collision queries (:class:`~ltamp_cli.backends.pybullet.tamp.planning.PlanningWorld`).

GoodPour and GoodScoop are learned: ``world.learned_streams.sample-pour`` /
``sample-scoop`` (``model`` relative to this folder; defaults ``../../models/kitchen3d/pour``
and ``.../scoop`` with the ``adaptive`` sampler) yield controls from the GP level-set model's
confident set, each passing the skill's geometric pre-check; each control's tool path is
followed by the arm (``follow-obj-path``) or skipped. Dump, stir and push are engineered
paths (:mod:`ltamp_cli.backends.pybullet.tamp.skill_paths`).

**Physics pre-check** (opt-in, ``world.precheck: [pour]``): a GoodPour control the arm can
follow is also run once as the skill's own PyBullet trial (the simulation the model was learned
from: the scene's cup and bowl, trial seed 0) with 30 beads instead of ~100 (0.5-1 s of CPU
instead of 2-3 s; on 8 controls it gave the full trial's verdict but for one that poured 97 %
(93 % with 30 beads) and 89 % on SAPIEN), and the control is dropped unless its score is at
least ``world.precheck_min_score`` (default 0.5: 95 % of the beads in the bowl, a margin over
the skill's success at 90 %, so that the pour still succeeds on another engine). The model of
60 trials cannot tell such margins: its mean/std ranks controls that pour only 70-80 % (a cup
tilted just past horizontal) above ones that pour everything. Controls that passed are tried
first for the next inputs with the same context (another grasp); at most
``world.precheck_limit`` (default 3) new trials are run per stream call (the call then ends).
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable, Iterator, Mapping
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.backends.protocol import SkillSpec
from ltamp_cli.backends.pybullet.backend import Kitchen3DBackend
from ltamp_cli.backends.pybullet.skills.pour import PourSettings, pour_is_valid
from ltamp_cli.backends.pybullet.skills.scoop import scoop_is_valid
from ltamp_cli.backends.pybullet.tamp import skill_paths
from ltamp_cli.backends.pybullet.tamp.planning import PlanningWorld
from ltamp_cli.backends.pybullet.tamp.scene import scene_from_world
from ltamp_cli.backends.pybullet.tamp.values import ArmConf, ArmPath, GraspValue, as_conf
from ltamp_cli.backends.skills3d.pour import POUR_SPEC
from ltamp_cli.backends.skills3d.scoop import SCOOP_SPEC
from ltamp_cli.errors import InputError
from ltamp_cli.learned_streams.stream import (
    LearnedStream,
    LearnedStreamConfig,
    learned_stream_configs,
)
from ltamp_cli.planner.keyed_random import KeyedRandom
from ltamp_cli.planner.streams import Binding, StreamInfo

HERE = Path(__file__).resolve().parent
#: Controls a learned stream call tries before reporting "nothing this call".
TRIES_PER_CALL = 8
DEFAULT_LEARNED = {
    "sample-pour": {"model": "../../models/kitchen3d/pour", "sampler": "adaptive"},
    "sample-scoop": {"model": "../../models/kitchen3d/scoop", "sampler": "adaptive"},
}
#: Motion searches (each a separate stream call) between two confs, and how many distinct
#: paths they may give at most.
MOTION_ATTEMPTS = 3
MOTION_ALTERNATIVES = 2
#: Targets of tool skills (pour, scoop, dump, stir) farther than this (m, horizontally) from
#: an arm's base are out of its reach: the Panda reaches 0.855 m, plus the held tool and the
#: skill's offsets; pours were found up to 0.92 m. Skipping them spares futile IK.
MAX_TOOL_REACH_M = 1.05
#: Skill-frame yaws tried around a target, as offsets from the heading of the arm's base
#: to the target (radians): facing the arm first, then further round.
YAW_OFFSETS = tuple(k * math.pi / 4 for k in (0, 1, -1, 2, -2, 3, -3, 4))
#: Dumps roll the spoon sideways: the wrist manages that best with the spoon turned well
#: round from the arm's heading (found by trying every yaw in the coffee scene), so those
#: yaws come first.
DUMP_YAW_OFFSETS = tuple(k * math.pi / 4 for k in (3, -2, 2, 1, 4, -3, -1, 0))

#: Push hand yaws, as offsets from the push line's heading (radians): the fingers across
#: the line, the same turned round, then along it (flat-faced objects only).
PUSH_YAW_OFFSETS = (0.0, math.pi, math.pi / 2)


#: Placements keep this far (m, footprint to footprint) from other movable objects where
#: they stand, if one of this many uniform draws does.
PLACEMENT_ROOM_M = 0.08
PLACEMENT_DRAWS = 25
#: Skills that have a physics pre-check, its default trials per stream call and least score.
PRECHECK_SKILLS = ("pour",)
PRECHECK_LIMIT = 3
PRECHECK_MIN_SCORE = 0.5
#: The pre-check's beads per trial (a normal of this mean, sd 10, within ±5).
PRECHECK_BEADS = 30


def _xy(value: Any) -> tuple[float, float]:
    return (round(float(value[0]), 4), round(float(value[1]), 4))


class PhysicsCheck:
    """The opt-in physics pre-check of a learned skill: ``check(context (dα,), control
    (dθ,)) -> bool`` runs the skill's PyBullet trial (seed 0) and passes scores of at least
    ``min_score``. ``limit`` trials per stream call: :meth:`begin` starts a call's budget,
    :attr:`spent` says it is used up. Results are remembered per control; ``checked`` and
    ``rejected`` count trials."""

    def __init__(self, skill: str, limit: int, min_score: float) -> None:
        self.skill = skill
        self.limit = limit
        self.min_score = min_score
        self.left = limit
        self.checked = 0
        self.rejected = 0
        self._backend: Kitchen3DBackend | None = None
        self._known: dict[tuple[float, ...], bool] = {}
        self._passed: dict[tuple[float, ...], list[np.ndarray]] = {}

    def passed(self, context: np.ndarray) -> list[np.ndarray]:
        """Controls that passed their trial in ``context``, oldest first."""
        return list(self._passed.get(tuple(round(float(v), 9) for v in context), ()))

    def begin(self) -> None:
        self.left = self.limit

    @property
    def spent(self) -> bool:
        return self.left <= 0

    def __call__(self, context: np.ndarray, control: np.ndarray) -> bool:
        key = tuple(round(float(v), 9) for v in (*context, *control))
        if key in self._known:
            return self._known[key]
        if self.spent:
            return False
        if self._backend is None:  # one physics world, connected on first use, reused
            beads = PourSettings(bead_count=PRECHECK_BEADS)
            self._backend = Kitchen3DBackend(pour_settings=beads)
            weakref.finalize(self, self._backend.close)
        self.left -= 1
        result = self._backend.run_trial(self.skill, context, control, 0)
        ok = bool(result.valid and result.score >= self.min_score)
        self.checked += 1
        self.rejected += not ok
        self._known[key] = ok
        if ok:
            self._passed.setdefault(key[:len(context)], []).append(np.array(control))
        return ok


def _precheck(world: Mapping[str, Any], skill: str) -> PhysicsCheck | None:
    """``skill``'s pre-check if ``world.precheck`` lists it (none by default)."""
    raw = world.get("precheck", []) or []
    if not isinstance(raw, list) or any(name not in PRECHECK_SKILLS for name in raw):
        raise InputError(f"world.precheck: expected a list of skills among "
                         f"{', '.join(PRECHECK_SKILLS)}, got {raw!r}")
    limit = world.get("precheck_limit", PRECHECK_LIMIT)
    if isinstance(limit, bool) or not isinstance(limit, int) or limit < 1:
        raise InputError(f"world.precheck_limit: expected an integer >= 1, got {limit!r}")
    score = world.get("precheck_min_score", PRECHECK_MIN_SCORE)
    if isinstance(score, bool) or not isinstance(score, int | float) or not -1 <= score <= 1:
        raise InputError(f"world.precheck_min_score: expected a number in [-1, 1] (the "
                         f"skill's score), got {score!r}")
    return PhysicsCheck(skill, limit, float(score)) if skill in raw else None


class _LearnedSkill:
    """A learned stream loaded on first use, with the planner's feedback wired to it, whose
    calls try a few controls before giving the planner back control (also as soon as a
    physics pre-check ``check`` has spent the call's trials)."""

    def __init__(self, config: LearnedStreamConfig, to_context: Callable[..., np.ndarray],
                 to_outputs: Callable[..., tuple[Any, ...] | None],
                 keyed: KeyedRandom, name: str, check: PhysicsCheck | None = None,
                 skill: SkillSpec | None = None) -> None:
        self._args = (config, to_context, to_outputs, keyed(name))
        self._draws_for = partial(keyed, name)  # a generator per input tuple
        # the model must be of this skill (its parameter names), not merely of its size
        self._names = ({} if skill is None else
                       {"context_names": skill.context.names,
                        "control_names": skill.control.names})
        self.stream: LearnedStream | None = None
        self.check = check

    def __call__(self, *inputs: Any) -> Iterator[list[tuple[Any, ...]]]:
        if self.stream is None:  # the model is loaded on first use only
            self.stream = LearnedStream(*self._args, rng_for=self._draws_for, **self._names)
        if self.check is not None:
            # Controls that passed their trial for other inputs (another grasp of the cup)
            # first: the trial depends on the context only, so they cost no new trial.
            context = np.asarray(self._args[1](*inputs), dtype=float)
            for control in self.check.passed(context):
                reused = self._args[2](control, *inputs)
                if reused:
                    yield [tuple(reused)]
            self.check.begin()
        misses = 0
        for outputs in self.stream(*inputs):
            if outputs:
                misses = 0
                yield [outputs]
            else:
                misses += 1
                # The most confident controls are often out of the arm's reach: try a few
                # per call so that one call usually succeeds, but give the planner back
                # control now and then.
                if misses % TRIES_PER_CALL == 0 or (self.check is not None
                                                    and self.check.spent):
                    yield []
                else:
                    continue
            if self.check is not None:  # the next call of the planner's has its own trials
                self.check.begin()

    def feedback(self, inputs: tuple[Any, ...], outputs: tuple[Any, ...]) -> None:
        if self.stream is not None:
            self.stream.on_unusable(inputs, outputs)


def make_streams(world: Mapping[str, Any], rng: np.random.Generator) -> dict[str, Any]:
    scene = scene_from_world(world)
    planning = PlanningWorld(scene)
    learned = {**DEFAULT_LEARNED, **dict(world.get("learned_streams", {}) or {})}
    configs = learned_stream_configs({"learned_streams": learned}, HERE)
    pour_check = _precheck(world, "pour")
    table_z = planning.table_z
    # Every instance draws from its own generator, keyed by its stream and inputs: the
    # samples one stream gives do not depend on how many draws the others made (a new
    # scoop model would otherwise reshuffle every pour, grasp and motion after it).
    keyed = KeyedRandom(rng)
    # What must stand where whenever an arm is at a conf: a pick/place conf of object o at
    # pose p has o at p (it is about to be picked or has just been placed). Motions to and
    # from such confs avoid those objects (they would otherwise sweep through the object
    # the arm reaches for, and the planner, seeing it via CFreeTraj, had no other path).
    standing_at: dict[ArmConf, set[tuple[str, tuple[float, float]]]] = {}
    # Poses of movable objects given by the problem (seen in stream inputs, not sampled
    # here): an object given one pose most likely stands there for much of the plan, so
    # motions first try to keep clear of it (a block carried away from beside the cup swept
    # through the cup, and the planner then chained extra placements to get round it).
    sampled: set[tuple[str, tuple[float, float]]] = set()
    given: dict[str, set[tuple[float, float]]] = {}

    def seen(name: str, pose: Any) -> None:
        xy = _xy(pose)
        if not scene.object(name).fixed and (name, xy) not in sampled:
            given.setdefault(name, set()).add(xy)

    def arm_of(r: Any) -> int | None:
        arm = int(r)
        return arm if 0 <= arm < scene.n_arms else None

    def in_reach(arm: int | None, pose: Any) -> bool:
        if arm is None:
            return False
        xy = _xy(pose)
        base = planning.base_xy(arm)
        return math.hypot(xy[0] - base[0], xy[1] - base[1]) <= MAX_TOOL_REACH_M

    def yaws(arm: int, xy: tuple[float, float], offsets: tuple[float, ...] = YAW_OFFSETS
             ) -> list[float]:
        heading = planning.base_yaw(arm, xy)
        return [heading + offset for offset in offsets]

    def sample_placement(name: str, region: str) -> Iterator[tuple[tuple[float, float]]]:
        area = scene.regions[region]
        half = scene.object(name).footprint()
        if area.x[1] - area.x[0] < 2 * half[0] or area.y[1] - area.y[0] < 2 * half[1]:
            return
        draws = keyed("sample-placement", name, region)

        def draw() -> tuple[float, float]:
            return (round(float(draws.uniform(area.x[0] + half[0], area.x[1] - half[0])), 4),
                    round(float(draws.uniform(area.y[0] + half[1], area.y[1] - half[1])), 4))

        def roomy(xy: tuple[float, float]) -> bool:
            """A hand's room from every other movable object at its one given pose."""
            for other, poses in given.items():
                if other == name or len(poses) != 1:
                    continue
                (ox, oy), other_half = next(iter(poses)), scene.object(other).footprint()
                gap = max(abs(xy[0] - ox) - half[0] - other_half[0],
                          abs(xy[1] - oy) - half[1] - other_half[1])
                if gap < PLACEMENT_ROOM_M:
                    return False
            return True

        while True:
            # Placements that leave a hand's room round the other objects first: one next
            # to the cup blocks its grasps or the arm's way to it again, and the planner
            # would test and discard many of them (with a pour sampled for each skeleton).
            xy = draw()
            for _ in range(PLACEMENT_DRAWS - 1):
                if roomy(xy):
                    break
                xy = draw()
            sampled.add((name, xy))
            yield (xy,)

    def sample_grasp(name: str) -> Iterator[tuple[GraspValue]]:
        for value in planning.grasp_values(name):
            yield (value,)

    def inverse_kinematics(r: Any, name: str, pose: Any, grasp: GraspValue
                           ) -> Iterator[list[tuple[ArmConf, ArmPath]]]:
        arm = arm_of(r)
        seen(name, pose)
        if arm is None:
            return
        draws = keyed("inverse-kinematics", arm, name, _xy(pose), tuple(grasp))
        found = list(planning.pick_kinematics(name, _xy(pose), tuple(grasp),  # type: ignore[arg-type]
                                              draws, arms=(arm,)))
        for conf, _ in found:
            standing_at.setdefault(conf, set()).add((name, _xy(pose)))
        yield found

    def motion(r: Any, q1: ArmConf, q2: ArmConf, held: tuple[str, GraspValue] | None
               ) -> Iterator[list[tuple[ArmPath]]]:
        a, b = as_conf(q1), as_conf(q2)
        if a.arm != arm_of(r) or b.arm != a.arm:
            return
        standing = standing_at.get(a, set()) | standing_at.get(b, set())
        names = [name for name, _ in standing]
        # An object held, or (ambiguously) at two poses, is not an obstacle of this motion.
        standing = {(name, xy) for name, xy in standing
                    if names.count(name) == 1 and (held is None or held[0] != name)}
        named = {name for name, _ in standing} | ({held[0]} if held else set())
        likely = {(name, next(iter(poses))) for name, poses in given.items()
                  if len(poses) == 1 and name not in named and name not in names}
        # A failed search yields nothing *this* call and may be retried later; a found path
        # may still hit a movable object elsewhere (CFreeTraj), so a later call gives
        # another one (a new RRT-Connect seed).
        found = 0
        for attempt in range(MOTION_ATTEMPTS):
            # The first path also keeps clear of the likely obstacles; a later one need not.
            avoid = standing | likely if found == 0 else standing
            seed = keyed.seed("motion", a, b, held, attempt)
            path = planning.plan_motion(a, b, held, seed, sorted(avoid),
                                        straight_first=found == 0)
            yield [] if path is None else [(path,)]
            found += path is not None
            if found >= MOTION_ALTERNATIVES:
                return

    def plan_free_motion(r: Any, q1: ArmConf, q2: ArmConf) -> Iterator[list[tuple[ArmPath]]]:
        yield from motion(r, q1, q2, None)

    def plan_holding_motion(r: Any, name: str, grasp: GraspValue, q1: ArmConf, q2: ArmConf
                            ) -> Iterator[list[tuple[ArmPath]]]:
        yield from motion(r, q1, q2, (name, tuple(grasp)))  # type: ignore[arg-type]

    # Learned skills ----------------------------------------------------------------------

    def pour_outputs(control: np.ndarray, r: Any, cup: str, grasp: GraspValue, bowl: str,
                     pose: Any) -> tuple[Any, ...] | None:
        arm = arm_of(r)
        g: GraspValue = tuple(grasp)  # type: ignore[assignment]
        context = skill_paths.pour_context(scene.object(cup), scene.object(bowl))
        # The skill's pre-check (~50 ms) runs on the sampled control only, not inside the
        # sampler on its thousands of candidates; None makes the learned stream draw again.
        if arm is None or not bool(pour_is_valid(context, control[None, :])[0]):
            return None
        for psi, phi in planning.skill_yaws(cup, g, arm):
            poses = skill_paths.pour_tool_poses(scene.object(cup), scene.object(bowl), _xy(pose),
                                                table_z, control, psi, phi)
            draws = keyed("pour-path", arm, cup, g, bowl, _xy(pose), control, psi, phi)
            path = planning.follow_object_path(cup, g, poses, arm, draws, "pour", target=bowl)
            if path is not None:
                # The physics pre-check only for controls the arm can follow (IK is the
                # more selective test, and ~5x cheaper than a trial).
                if pour_check is not None and not pour_check(context, control):
                    return ()
                return (path.start, path, tuple(round(float(v), 6) for v in control))
        # Not None: the learned stream would silently draw again; an empty tuple lets the
        # planner's call end ("nothing this call") and try other streams meanwhile.
        return ()

    def scoop_outputs(control: np.ndarray, r: Any, spoon: str, grasp: GraspValue, bowl: str,
                      pose: Any) -> tuple[Any, ...] | None:
        arm = arm_of(r)
        g: GraspValue = tuple(grasp)  # type: ignore[assignment]
        context = skill_paths.scoop_context(scene.object(bowl), scene.object(spoon))
        if arm is None or not bool(scoop_is_valid(context, control[None, :])[0]):
            return None
        for psi in yaws(arm, _xy(pose)):
            poses = skill_paths.scoop_tool_poses(scene.object(bowl), scene.object(spoon),
                                                 _xy(pose), table_z, control, psi)
            draws = keyed("scoop-path", arm, spoon, g, bowl, _xy(pose), control, psi)
            path = planning.follow_object_path(spoon, g, poses, arm, draws, "scoop",
                                               target=bowl)
            if path is not None:
                return (path.start, path.end, path, tuple(round(float(v), 6) for v in control))
        return ()

    pour = _LearnedSkill(
        configs["sample-pour"],
        lambda r, cup, grasp, bowl, pose: skill_paths.pour_context(scene.object(cup),
                                                                   scene.object(bowl)),
        pour_outputs, keyed, "sample-pour", pour_check, POUR_SPEC)
    scoop = _LearnedSkill(
        configs["sample-scoop"],
        lambda r, spoon, grasp, bowl, pose: skill_paths.scoop_context(scene.object(bowl),
                                                                      scene.object(spoon)),
        scoop_outputs, keyed, "sample-scoop", skill=SCOOP_SPEC)

    def sample_pour(r: Any, cup: str, grasp: GraspValue, bowl: str, pose: Any
                    ) -> Iterator[list[tuple[Any, ...]]]:
        if scene.object(cup).kind != "cup" or scene.object(bowl).kind not in (
                "bowl", "cup") or not in_reach(arm_of(r), pose):
            return
        yield from pour(r, cup, grasp, bowl, pose)

    def sample_scoop(r: Any, spoon: str, grasp: GraspValue, bowl: str, pose: Any
                     ) -> Iterator[list[tuple[Any, ...]]]:
        if scene.object(spoon).kind != "spoon" or scene.object(bowl).kind != "bowl" or not in_reach(
                arm_of(r), pose):
            return
        yield from scoop(r, spoon, grasp, bowl, pose)

    # Engineered skills -------------------------------------------------------------------

    def sample_dump(r: Any, spoon: str, grasp: GraspValue, cup: str, pose: Any
                    ) -> Iterator[list[tuple[ArmConf, ArmPath]]]:
        arm = arm_of(r)
        if arm is None or scene.object(spoon).kind != "spoon" or scene.object(cup).kind not in (
                "bowl", "cup") or not in_reach(arm, pose):
            return
        g: GraspValue = tuple(grasp)  # type: ignore[assignment]
        for psi in yaws(arm, _xy(pose), DUMP_YAW_OFFSETS):
            for sign in (1.0, -1.0):
                poses = skill_paths.dump_tool_poses(scene.object(spoon), scene.object(cup),
                                                    _xy(pose), table_z, psi, sign)
                draws = keyed("dump-path", arm, spoon, g, cup, _xy(pose), psi, sign)
                path = planning.follow_object_path(spoon, g, poses, arm, draws, "dump")
                yield [] if path is None else [(path.start, path)]

    def sample_stir(r: Any, stirrer: str, grasp: GraspValue, cup: str, pose: Any
                    ) -> Iterator[list[tuple[ArmConf, ArmPath]]]:
        arm = arm_of(r)
        if arm is None or scene.object(stirrer).kind != "stirrer" or scene.object(
                cup).kind not in ("bowl", "cup") or not in_reach(arm, pose):
            return
        g: GraspValue = tuple(grasp)  # type: ignore[assignment]
        for phi in YAW_OFFSETS:  # the rod is symmetric: its spin only changes the wrist
            poses = skill_paths.stir_tool_poses(scene.object(stirrer), scene.object(cup),
                                                _xy(pose), table_z, phi)
            draws = keyed("stir-path", arm, stirrer, g, cup, _xy(pose), phi)
            path = planning.follow_object_path(stirrer, g, poses, arm, draws, "stir")
            yield [] if path is None else [(path.start, path)]

    def sample_push(r: Any, name: str, start: Any, goal: Any
                    ) -> Iterator[list[tuple[ArmConf, ArmConf, ArmPath]]]:
        arm = arm_of(r)
        a, b = _xy(start), _xy(goal)
        if arm is None or a == b:
            return
        obj = scene.object(name)
        heading = math.atan2(b[1] - a[1], b[0] - a[0])
        # Fingers across the line (either way round), then along it; a round object only
        # across (open, two contacts: the one contact of fingers along the line does not
        # hold it on the line, skill_paths.push_holds_line).
        for offset in PUSH_YAW_OFFSETS:
            hand_yaw = heading + offset
            if not skill_paths.push_holds_line(obj, a, b, hand_yaw):
                continue
            poses = skill_paths.push_hand_poses(obj, a, b, table_z, hand_yaw)
            gap = skill_paths.push_hand_gap(obj, a, b, hand_yaw)
            draws = keyed("push-path", arm, name, a, b, offset)
            path = planning.follow_hand_path(poses, arm, draws, "push", touching=name,
                                             finger_gap=gap)
            if path is not None and planning.approach_collides(path, name, a, poses[1]):
                path = None  # the hand would come down on the object, not behind it
            yield [] if path is None else [(path.start, path.end, path)]

    def test_reach(r: Any, name: str, pose: Any) -> bool:
        # One bound for picks, pushes and tool skills: a pick's IK never succeeded beyond
        # 0.95 m (cup, 12 grasps; 2/12 at 0.9 m), pours reached 0.92 m with the held cup.
        return in_reach(arm_of(r), pose)

    def test_cfree(a: str, pa: Any, b: str, pb: Any) -> bool:
        return not planning.footprints_overlap(a, _xy(pa), b, _xy(pb))

    def test_cfree_traj(path: ArmPath, name: str, pose: Any) -> bool:
        seen(name, pose)
        return not planning.path_collides(path, name, _xy(pose))

    def distance(r: Any, q1: ArmConf, q2: ArmConf) -> float:
        return round(1.0 + float(np.linalg.norm(as_conf(q1).array - as_conf(q2).array)), 4)

    return {
        "sample-placement": Binding(sample_placement, StreamInfo(overhead=0.01)),
        "sample-grasp": Binding(sample_grasp, StreamInfo(overhead=0.01)),
        "inverse-kinematics": Binding(inverse_kinematics, StreamInfo(p_success=0.5,
                                                                     overhead=0.1)),
        "plan-free-motion": Binding(plan_free_motion, StreamInfo(overhead=0.2)),
        "plan-holding-motion": Binding(plan_holding_motion, StreamInfo(overhead=0.2)),
        "sample-pour": Binding(sample_pour, StreamInfo(p_success=0.5, overhead=1.0),
                               on_unusable=pour.feedback),
        "sample-scoop": Binding(sample_scoop, StreamInfo(p_success=0.5, overhead=1.0),
                                on_unusable=scoop.feedback),
        "sample-dump": Binding(sample_dump, StreamInfo(p_success=0.5, overhead=0.5)),
        "sample-stir": Binding(sample_stir, StreamInfo(p_success=0.5, overhead=0.5)),
        "sample-push": Binding(sample_push, StreamInfo(p_success=0.5, overhead=0.5)),
        "test-reach": Binding(test_reach, StreamInfo(eager=True, overhead=0.001)),
        "test-cfree": Binding(test_cfree, StreamInfo(eager=True, overhead=0.001)),
        "test-cfree-traj": Binding(test_cfree_traj, StreamInfo(eager=True, overhead=0.01)),
        "distance": distance,
    }


__all__ = ["make_streams"]
