"""Replaying kitchen2d plans in Box2D and checking the goal in the simulated world.

Each plan action is executed with real physics: the gripper follows the planned paths,
grasps by contact (both fingers must touch the object), pours/scoops with the controls the
learned streams chose, and the faucet fills whatever cup stands under it. At the end the
goal facts are checked from particle positions and object poses, never from the plan.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from Box2D import b2

from ltamp_cli.backends.box2d.gripper import body_pose
from ltamp_cli.backends.box2d.particles import inside_box
from ltamp_cli.backends.box2d.render import FrameRecorder, Region, View
from ltamp_cli.backends.box2d.scene import (
    LiveScene,
    SceneSpec,
    build_scene,
    scene_from_world,
)
from ltamp_cli.backends.box2d.skills import pour as pour_skill
from ltamp_cli.backends.box2d.skills import scoop as scoop_skill
from ltamp_cli.backends.box2d.tamp import (
    KitchenGeometry,
    Point,
    approach_opening,
    empty_hand_path,
)
from ltamp_cli.backends.execution import ExecutionReport
from ltamp_cli.backends.frames import GifTiming, action_caption
from ltamp_cli.motion.timing import MotionLimits, planar_limits, time_path

SPEED = 14.0
SLOW = 3.0
HOLD_SPEED = 6.0
#: Largest hand acceleration (u/s²) of every executed motion, and of its rotations
#: (rad/s², with ``ANGULAR_SPEED`` rad/s): motions start and stop at rest at every path
#: corner. Speed-only limits threw carried liquid ~2 units up when a cup was set down.
ACCELERATION = 5.0
ANGULAR_SPEED = 1.0
ANGULAR_ACCELERATION = 2.0
#: Fraction of a cup's inner width the stirrer's paddle must sweep for ``Stirred``.
STIR_COVERAGE = 0.6
#: Fraction of a poured/filled material that must end in the cup for ``Contains``.
CONTAINS_FRACTION = 0.9
#: Static obstacles the hand must never enter (Box2D does not collide kinematic bodies,
#: such as the hand and what it holds, with static ones: the run checks overlaps itself).
GUARDED = ("wall", "holder")
#: Check the hand against them every this many physics steps.
GUARD_EVERY = 4


class ActionFailed(RuntimeError):
    """An action could not be carried out physically (e.g. a grasp closed on nothing)."""


def resolve_pose(spec: SceneSpec, name: str, pose: Any) -> Point:
    """Symbolic initial poses (PDDL objects without a value) are the object's home."""
    if isinstance(pose, str):
        return (round(spec.object(name).home, 4), round(spec.layout.table_top, 4))
    return (float(pose[0]), float(pose[1]))


class Kitchen2DRun:
    """One execution: a live scene plus bookkeeping of what the actions achieved."""

    def __init__(self, spec: SceneSpec, seed: int, recorder: FrameRecorder | None) -> None:
        self.spec = spec
        self.geometry = KitchenGeometry(spec)
        self.scene: LiveScene = build_scene(spec, seed, recorder)
        self.stirred: dict[str, bool] = {}
        self.sugar_dumped: dict[str, int] = {}
        self.n_created = len(self.scene.kitchen.particles)
        self.log: list[dict[str, Any]] = []
        #: Every timed hand trajectory ``(m, 3)`` the run commanded (its first row the pose
        #: it started from, at rest), in order.
        self.commanded: list[np.ndarray] = []
        self.obstacles = [b for b in self.scene.kitchen.world.bodies
                          if b.userData and b.userData.get("name") in GUARDED]
        #: First static obstacle the hand (or what it holds) overlapped, if any.
        self.hit: str = ""
        if self.obstacles:
            self.scene.kitchen.observers.append(self._guard)

    def _guard(self, kitchen: Any) -> None:
        if self.hit or kitchen.steps % GUARD_EVERY:
            return
        movers = list(self.gripper.bodies)
        if self.gripper.held is not None:
            movers.append(self.gripper.held)
        for mover in movers:
            for obstacle in self.obstacles:
                for fa in mover.fixtures:
                    for fb in obstacle.fixtures:
                        if (fb.userData or {}).get("part") == "base":
                            continue
                        if b2.testOverlap(fa.shape, 0, fb.shape, 0, mover.transform,
                                          obstacle.transform):
                            self.hit = obstacle.userData["name"]
                            return

    # --- motion primitives ---------------------------------------------------------------
    @property
    def gripper(self) -> Any:
        return self.scene.gripper

    def track(self, poses: np.ndarray) -> None:
        """Command the timed hand poses ``(m, 3)``, one per physics step, and keep them,
        after the pose they start from, in :attr:`commanded` (what a test checks the
        accelerations of)."""
        self.commanded.append(np.concatenate([np.array([self.gripper._target]), poses]))
        self.gripper.track(poses)

    def follow(self, path: Sequence[Sequence[float]], speed: float = SPEED,
               angle: float = 0.0) -> None:
        """Visit ``path``'s points in straight lines, starting and stopping at rest at every
        point with at most ``ACCELERATION`` (abrupt starts and stops throw grains out of
        a carried spoon or cup); the hand turns to ``angle`` on the first segment."""
        start = self.gripper._target
        poses = np.array([start, *((float(x), float(y), angle) for x, y in path)])
        limits = planar_limits(speed, ANGULAR_SPEED, ACCELERATION, ANGULAR_ACCELERATION)
        self.track(time_path(poses, limits, self.scene.kitchen.config.dt)[1:])

    def rotate_about(self, pivot: Point, in_hand: Point, goal: float, speed: float) -> None:
        """Turn the gripper to ``goal`` keeping the point ``in_hand`` (gripper frame) at
        ``pivot`` in the world (where that point is now, if the hand is not exactly there),
        from rest to rest at most ``ANGULAR_ACCELERATION``. The hand
        then moves on a circle of radius ``|in_hand|``: its tangential (r·α) and centripetal
        (r·ω²) accelerations are kept to half of ``ACCELERATION`` each."""
        here = self.gripper._target
        start = here[2]
        # Turn about where the point in hand actually is: the plan's pivot can be off by a
        # centimetre or two, and jumping there in one step is an acceleration spike.
        c0, s0 = math.cos(start), math.sin(start)
        pivot = (here[0] + c0 * in_hand[0] - s0 * in_hand[1],
                 here[1] + s0 * in_hand[0] + c0 * in_hand[1])
        lever = math.hypot(*in_hand)
        accel, spin = ANGULAR_ACCELERATION, speed
        if lever > 1e-9:
            accel = min(accel, ACCELERATION / 2 / lever)
            spin = min(spin, math.sqrt(ACCELERATION / 2 / lever))
        limits = MotionLimits((spin,), (accel,))
        angles = time_path(np.array([[start], [goal]]), limits,
                           self.scene.kitchen.config.dt)[1:, 0]
        c, s = np.cos(angles), np.sin(angles)
        x = pivot[0] - (c * in_hand[0] - s * in_hand[1])
        y = pivot[1] - (s * in_hand[0] + c * in_hand[1])
        self.track(np.stack([x, y, angles], axis=1))

    def settle(self, max_time: float, rest_speed: float = 0.05) -> None:
        """Hold still until no particle moves (or ``max_time``); spill is frozen."""
        kitchen = self.scene.kitchen
        elapsed = 0.0
        while elapsed < max_time:
            self.gripper.hold(0.1)
            elapsed += 0.1
            if len(kitchen.particles) == 0:
                return
            self.sweep_spill()
            if np.all(kitchen.particle_speeds() < rest_speed):
                return

    def sweep_spill(self) -> int:
        """Grains lying on the table or the floor are spilled for good: they become static
        and collide with nothing, so a spoon or cup put down there stands on the table,
        not on a few frictionless grains. Returns how many grains were swept."""
        kitchen = self.scene.kitchen
        pos = kitchen.particle_positions()
        top = self.spec.layout.table_top
        spilled = (pos[:, 1] < top + 0.15) | (pos[:, 1] < top - 1.0)
        count = 0
        for body, flag in zip(kitchen.particles, spilled, strict=True):
            if flag and body.type != b2.staticBody:
                body.type = b2.staticBody
                for fixture in body.fixtures:
                    data = fixture.filterData
                    data.maskBits = 0
                    fixture.filterData = data
                count += 1
        return count

    # --- actions -------------------------------------------------------------------------
    def move(self, path: Sequence[Point], speed: float = SPEED) -> None:
        held = self.gripper.held
        name = (held.userData or {}).get("object") if held is not None else None
        cup = name is not None and self.spec.object(name).kind in ("cup", "bowl")
        before = sum(self.contents(name).values()) if cup else 0
        self.follow(path, speed=speed)
        if cup:
            # Carried contents: what a test checks stays in the cup.
            self.log.append({"carry": name, "before": before,
                             "after": sum(self.contents(name).values())})

    def pick(self, name: str, pose: Point, grasp: Point, approach: Sequence[Point]) -> None:
        empty = empty_hand_path(approach)
        self.gripper.move(self.gripper._target, opening=approach_opening(self.spec.object(name)))
        self.follow(empty[:-1])
        self.follow(empty[-1:], speed=SLOW)
        grasped = self.gripper.close()
        # SWIG makes a new proxy per access: compare the bodies' tags, not identities.
        if grasped is None or grasped.userData.get("object") != name:
            raise ActionFailed(f"pick {name}: the fingers did not close on it")
        self.follow(list(reversed(approach[:-1])), speed=SLOW)

    def place(self, name: str, pose: Point, grasp: Point, approach: Sequence[Point]) -> None:
        self.follow(approach[1:-1])
        self.follow(approach[-1:], speed=SLOW)
        self.gripper.release(open_fingers=False)
        self.gripper.move(self.gripper.pose, opening=approach_opening(self.spec.object(name)),
                          speed=1.0)
        self.gripper.hold(0.2)
        self.follow(list(reversed(empty_hand_path(approach)[:-1])), speed=SLOW)
        x, y, angle = body_pose(self.scene.bodies[name])
        if abs(x - pose[0]) > 0.5 or abs(y - pose[1]) > 0.3 or abs(angle) > 0.1:
            raise ActionFailed(f"place {name}: it came to rest at ({x:.2f}, {y:.2f}, "
                               f"{angle:.2f}) instead of ({pose[0]:.2f}, {pose[1]:.2f}, 0)")

    def push(self, name: str, approach: Sequence[Point], control: Sequence[float]) -> None:
        """Close the fingers above the block, go down beside it and push along the table
        like the skill's pusher: at ``PUSH_SPEED · cos(angle)`` for ``duration`` seconds
        (the x part of the learned push, see :meth:`KitchenGeometry.push_setup`), then
        come back up to the conf. Raises if the block did not move (the push missed it)."""
        conf, start, end = approach
        body = self.scene.bodies[name]
        x_before = float(body.position[0])
        self.gripper.move(self.gripper._target, opening=0.0)
        self.follow([conf])
        self.follow([start], speed=SLOW)
        dt = self.scene.kitchen.config.dt
        steps = max(1, round(float(control[3]) / dt))
        # ``end`` is the start plus PUSH_SPEED · cos(angle) · duration; like the skill's
        # pusher, the hand starts and stops at once (constant speed, no smooth profile).
        for k in range(1, steps + 1):
            x = start[0] + (end[0] - start[0]) * k / steps
            self.gripper.command((x, start[1], 0.0))
            self.scene.kitchen.step()
        self.gripper.hold(1.5)  # the block slides on, tips over the edge and lands
        self.follow([(self.gripper.pose[0], conf[1])], speed=SLOW)
        self.follow([conf])
        moved = abs(float(body.position[0]) - x_before)
        self.log.append({"push": name, "moved_x": round(moved, 3),
                         "end": [round(float(v), 3) for v in body.position]})
        if moved < 0.05:
            raise ActionFailed(f"push {name}: the pusher missed it (moved {moved:.3f})")

    def fill(self, name: str) -> None:
        faucet = self.scene.faucet
        if not faucet.cup_below():
            raise ActionFailed(f"fill {name}: no cup under the faucet")
        faucet.enabled = True
        limit = 2 * faucet.spec.capacity * faucet.spec.period + 100
        steps = 0
        while faucet.emitted < faucet.spec.capacity and steps < limit:
            self.gripper.hold(0.1)
            steps += 10
        faucet.enabled = False
        self.settle(3.0)
        self.stirred[name] = False

    def pour(self, source: str, target: str, pose: Point, approach: Sequence[Point],
             control: Sequence[float]) -> None:
        self.follow(approach[1:], speed=SLOW)
        # The skill's trials start tilting with the grains at rest; after a carry they
        # still slosh and would leave the mouth early, off the learned stream.
        self.settle(3.0)
        top = self.spec.layout.table_top
        item = self.spec.object(source)
        grasp = self.gripper._held_rel
        start = approach[-1]
        # Tilt like the skill: towards the target (sign(rel_x)) at its tilt speed.
        dangle = float(control[3])
        sense = pour_skill.tilt_sign(float(control[1]))
        tilt_speed = pour_skill.PourConfig().rotate_speed
        # Tilt as far as the control asks, or until the cup would touch the table.
        magnitude = 0.0
        step = tilt_speed * self.scene.kitchen.config.dt
        while magnitude < dangle - 1e-12:
            nxt = min(magnitude + step, dangle)
            corners = self.geometry.hand_corners(item, (-grasp[0], -grasp[1]), start[0],
                                                 start[1], sense * nxt)
            if corners[:, 1].min() < top:
                break
            magnitude = nxt
        self.rotate_about(start, (0.0, 0.0), sense * magnitude, tilt_speed)
        self.settle(10.0)
        self.log.append({"pour": source, "into": target, "contents": self.contents(target)})
        self.rotate_about(start, (0.0, 0.0), 0.0, 1.0)
        self.gripper.hold(0.3)
        self.follow(list(reversed(approach[:-1])), speed=SLOW)
        self.stirred[target] = False

    def scoop(self, spoon: str, bowl: str, pose: Point, approach: Sequence[Point],
              control: Sequence[float], conf: Point) -> None:
        config = scoop_skill.ScoopConfig()
        cup = self.spec.object(bowl).spec
        self.follow(approach[1:], speed=SLOW)
        spoon_path = scoop_skill.spoon_poses(np.array([cup.width, cup.height]),
                                             np.asarray(control, dtype=float), config)
        spoon_path = spoon_path + np.array([pose[0], pose[1] - self.spec.layout.table_top, 0])
        hand = self.gripper._held_rel
        hands = scoop_skill.hand_poses(spoon_path, (-hand[0], -hand[1]))
        self.commanded.append(np.concatenate([hands[:1], scoop_skill.timed_hands(
            hands, config, self.scene.kitchen.config.dt)]))
        scoop_skill.execute_scoop(self.gripper, hands, config)
        sp = self.spec.object(spoon).spec
        held = inside_box(self.scene.kitchen.particle_positions(), self.scene.bodies[spoon],
                          -sp.inner_width / 2, sp.inner_width / 2, sp.wall, sp.bowl_depth)
        self.log.append({"scoop": spoon, "in_spoon": int(held.sum())})
        up = (self.gripper.pose[0], conf[1])
        self.follow([up], speed=SLOW)
        self.follow([conf])

    def dump(self, spoon: str, target: str, approach: Sequence[Point],
             control: Sequence[float]) -> None:
        self.follow(approach[1:], speed=SLOW)
        spoon_body = self.scene.bodies[spoon]
        sp = self.spec.object(spoon).spec
        in_spoon = inside_box(self.scene.kitchen.particle_positions(), spoon_body,
                              -sp.inner_width / 2, sp.inner_width / 2, sp.wall, sp.bowl_depth)
        hand = self.gripper._held_rel
        centre_in_hand = (hand[0], hand[1] + sp.bowl_depth / 2)
        pivot = (float(control[0]), float(control[1]))
        self.rotate_about(pivot, centre_in_hand, float(control[2]), 1.5)
        self.gripper.hold(1.0)
        self.settle(3.0)
        self.rotate_about(pivot, centre_in_hand, 0.0, 1.5)
        self.follow(list(reversed(approach[:-1])), speed=SLOW)
        self.sugar_dumped[target] = self.sugar_dumped.get(target, 0) + int(in_spoon.sum())
        self.log.append({"dump": spoon, "in_spoon": int(in_spoon.sum())})
        self.stirred[target] = False

    def stir(self, stirrer: str, target: str, pose: Point, approach: Sequence[Point],
             control: Sequence[float]) -> None:
        self.follow(approach[1:], speed=SLOW)
        cup = self.spec.object(target).spec
        x0, y0 = self.gripper.pose[0], self.gripper.pose[1]
        amplitude, cycles = float(control[1]), int(control[2])
        swept = []
        strokes = []
        for _ in range(cycles):
            for side in (1.0, -1.0):
                strokes.append((x0 + side * amplitude, y0))
                swept.append(side * amplitude)
        self.follow([*strokes, (x0, y0)], speed=1.0)
        self.settle(2.0)
        self.follow(list(reversed(approach[:-1])), speed=SLOW)
        # Stirred: the paddle, down at the cup's floor, swept most of the cup's width.
        paddle = self.spec.object(stirrer).spec.paddle_width
        coverage = max(swept) - min(swept) + paddle
        self.stirred[target] = coverage >= STIR_COVERAGE * cup.inner_width
        self.log.append({"stir": target, "coverage": round(coverage / cup.inner_width, 3)})

    # --- goal ----------------------------------------------------------------------------
    def contents(self, name: str) -> dict[str, int]:
        """Particles of each material inside cup ``name`` (its interior box)."""
        body = self.scene.bodies[name]
        spec = self.spec.object(name).spec
        out: dict[str, int] = {}
        for particle in self.scene.kitchen.particles:
            material = particle.userData.get("material", "")
            pos = np.array([tuple(particle.position)])
            if inside_box(pos, body, -spec.inner_width / 2, spec.inner_width / 2, spec.wall,
                          spec.height)[0]:
                out[material] = out.get(material, 0) + 1
        return out

    def material_total(self, material: str) -> int:
        return len(self.scene.particles_of(material))

    def check_fact(self, predicate: str, args: Sequence[str]) -> tuple[bool, dict[str, Any]]:
        """Whether a goal fact holds physically, with the measurements used."""
        if predicate == "contains":
            name, material = args
            inside = self.contents(name).get(material, 0)
            if material == "sugar":
                # A quarter spoonful: a scoop succeeds from half a spoonful and a few grains
                # roll off on the way to the cup.
                need = max(1, scoop_skill.capacity(scoop_skill.ScoopConfig()) // 4)
            else:
                sources = [o for o in self.spec.objects if o.material == material]
                total = sum(o.n_particles for o in sources)
                if material == self.spec.faucet_material:
                    total += self.scene.faucet.spec.capacity
                need = max(1, math.ceil(CONTAINS_FRACTION * total))
            return inside >= need, {"inside": inside, "needed": need}
        if predicate == "stirred":
            return self.stirred.get(args[0], False), {}
        if predicate == "on":
            name, region = args
            x, y, angle = body_pose(self.scene.bodies[name])
            lay = self.spec.layout
            if region == "coaster":
                ok = (abs(x - lay.coaster_x) <= lay.coaster_width / 2
                      and abs(y - lay.table_top - lay.coaster_height) < 0.1)
            elif region == "faucet":
                ok = abs(x - lay.faucet_x) < 0.5 and abs(y - lay.table_top) < 0.1
            else:
                ok = lay.table_x0 <= x <= lay.table_x1 and abs(y - lay.table_top) < 0.1
            ok = ok and abs(angle) < 0.1
            return ok, {"x": round(x, 3), "y": round(y, 3), "angle": round(angle, 3)}
        if predicate == "offtable":
            x, y, _ = body_pose(self.scene.bodies[args[0]])
            return y < self.spec.layout.table_top - 1.0, {"y": round(y, 3)}
        raise ActionFailed(f"cannot check goal fact ({predicate} {' '.join(args)}) physically")

    def conservation(self) -> dict[str, Any]:
        kitchen = self.scene.kitchen
        pos = kitchen.particle_positions()
        return {
            "n_particles": len(pos),
            "n_expected": self.n_created + self.scene.faucet.emitted,
            "n_in_world": int(kitchen.in_bounds(pos).sum()) if len(pos) else 0,
        }


def goal_atoms(formula: Any) -> list[tuple[str, tuple[str, ...]]]:
    """The positive atoms of a conjunctive goal (``And`` of ``Atom``)."""
    from ltamp_cli.planner.pddl.syntax import And, Atom

    if isinstance(formula, Atom):
        return [(formula.predicate.lower(), tuple(a.lower() for a in formula.args))]
    if isinstance(formula, And):
        out = []
        for part in formula.parts:
            out += goal_atoms(part)
        return out
    raise ActionFailed("only conjunctions of positive facts can be checked physically")


def goal_regions(spec: SceneSpec, goal: Any) -> list[Region]:
    """Where the goal wants objects, to draw: the floor below the table for ``OffTable``,
    the coaster for ``On ... coaster`` (other facts are seen in the contents)."""
    lay = spec.layout
    regions = []
    for predicate, args in goal_atoms(goal):
        if predicate == "offtable":
            regions.append(Region((lay.table_x0 - 4.0, lay.table_top - 3.0, lay.table_x1 + 4.0,
                                   lay.table_top - 1.0), f"goal: {args[0]} below this line "
                                  "(off the table)", below=True))
        elif predicate == "on" and args[1] == "coaster":
            half = lay.coaster_width / 2
            regions.append(Region((lay.coaster_x - half, lay.table_top, lay.coaster_x + half,
                                   lay.table_top + 2.0), f"goal: {args[0]} on the coaster"))
    return regions


def diagnose(steps: Sequence[dict[str, Any]], facts: dict[str, dict[str, Any]],
             error: str) -> list[str]:
    """One line per thing that went wrong: the failed action, then every goal fact that does
    not hold with what was measured; a ``contains`` fact also gets the material's count in
    the cup after each step that changes contents, so a missed pour reads differently from
    grains lost later (e.g. ``cream in cup: pour#8=33, dump#21=33, stir#27=31``)."""
    out = [f"action failed: {error}"] if error else []
    for fact, measured in facts.items():
        if measured.get("holds"):
            continue
        values = ", ".join(f"{k}={v}" for k, v in measured.items() if k != "holds")
        line = f"{fact} does not hold ({values})" if values else f"{fact} does not hold"
        parts = fact.strip("()").split()
        if parts[0] == "contains" and len(parts) == 3:
            cup, material = parts[1], parts[2]
            trace = [f"{entry['action']}#{entry['step']}="
                     f"{entry['contents'].get(cup, {}).get(material, 0)}"
                     for entry in steps if "contents" in entry]
            if trace:
                line += f"; {material} in {cup} after: {', '.join(trace)}"
        out.append(line)
    return out


def _value(step: Any, index: int) -> Any:
    return step.values[index]


class Kitchen2DExecutor:
    """:class:`~ltamp_cli.backends.execution.PlanExecutor` for the kitchen2d domain."""

    def __init__(self, every: int = 20, scale: float = 12.0,
                 timing: GifTiming | None = None) -> None:
        self.every = every
        self.scale = scale
        self.timing = timing or GifTiming()

    def execute(self, problem: Any, plan_result: Any, seed: int,
                render_path: str | Path | None = None) -> ExecutionReport:
        spec = scene_from_world(problem.world, np.random.default_rng(seed))
        recorder = None
        if render_path is not None:
            lay = spec.layout
            bounds = (lay.table_x0 - 2, lay.table_top - 3, lay.table_x1 + 2, lay.faucet_y + 9)
            pushes = any(item.kind == "block" for item in spec.objects)
            if pushes:
                # A block may be pushed off the table: a 4:3 window, zoomed in up to 3x,
                # follows the hand and the block down to the floor.
                half = 12.0
                middle = (lay.table_x0 + lay.table_x1) / 2
                bounds = (middle - half, lay.table_top - 9.0, middle + half,
                          lay.table_top + 9.0)
            recorder = FrameRecorder(self.every, View(bounds, self.scale * (3 if pushes else 1)),
                                     follow=pushes, regions=goal_regions(spec, problem.goal))
        if recorder is not None:
            recorder.caption = f"0/{len(plan_result.plan)}  initial state"
        run = Kitchen2DRun(spec, seed, recorder)
        steps: list[dict[str, Any]] = []
        success = True
        error = ""
        for number, step in enumerate(plan_result.plan, start=1):
            if recorder is not None:
                recorder.caption = action_caption(number, len(plan_result.plan), step.name,
                                                  step.args)
            try:
                self._dispatch(run, step)
                if run.hit:
                    raise ActionFailed(f"{step.name} {' '.join(step.args[:1])}: the hand "
                                       f"went into the {run.hit}")
                run.sweep_spill()
                entry = {"step": number, "action": step.name, "ok": True}
                if step.name.lower() in ("fill", "pour", "dump", "stir"):
                    entry["contents"] = {c.name: run.contents(c.name) for c in spec.objects
                                         if c.kind == "cup"}
                steps.append(entry)
            except ActionFailed as failure:
                steps.append({"step": number, "action": step.name, "ok": False,
                              "error": str(failure)})
                success, error = False, str(failure)
                break
        facts = {}
        goal_holds = success
        for predicate, args in goal_atoms(problem.goal):
            try:
                holds, measured = run.check_fact(predicate, args)
            except ActionFailed as failure:
                holds, measured = False, {"error": str(failure)}
            facts[f"({predicate} {' '.join(args)})"] = {"holds": holds, **measured}
            goal_holds = goal_holds and holds
        conservation = run.conservation()
        if recorder is not None:
            # A last second of frames saying how it ended (after everything was measured).
            recorder.caption = "goal " + ("holds" if goal_holds else "does not hold")
            run.scene.kitchen.step(round(1.0 / run.scene.kitchen.config.dt))
        details: dict[str, Any] = {
            "steps": steps,
            "goal": facts,
            "diagnosis": diagnose(steps, facts, error),
            "particles": conservation,
            "sim_time_s": round(run.scene.kitchen.time, 3),
            "log": run.log,
        }
        if error:
            details["error"] = error
        if recorder is not None and recorder.frames:
            written = recorder.save(render_path, self.timing)  # type: ignore[arg-type]
            details["render"] = str(render_path)
            details["animation"] = written
        return ExecutionReport(success, bool(goal_holds), details)

    def _dispatch(self, run: Kitchen2DRun, step: Any) -> None:
        name = step.name.lower()
        v: Callable[[int], Any] = lambda i: _value(step, i)  # noqa: E731
        args = [a.lower() for a in step.args]
        spec = run.spec
        if name == "move-free":
            run.move(v(1))
        elif name == "move-holding":
            # Gently with grains aboard (sloshing spills them), briskly otherwise.
            run.move(v(3), speed=HOLD_SPEED)
        elif name in ("pick", "place"):
            obj = args[0]
            pose = resolve_pose(spec, obj, v(1))
            action = run.pick if name == "pick" else run.place
            action(obj, pose, tuple(v(2)), v(4))
        elif name == "fill":
            run.fill(args[0])
        elif name == "push":
            # push ?o ?p ?e ?q ?a ?u
            run.push(args[0], v(4), v(5))
        elif name == "pour":
            # pour ?k ?g ?c ?p ?q ?a ?u ?m
            run.pour(args[0], args[2], resolve_pose(spec, args[2], v(3)), v(5), v(6))
        elif name == "scoop":
            # scoop ?s ?g ?b ?p ?q ?a ?u ?m
            run.scoop(args[0], args[2], resolve_pose(spec, args[2], v(3)), v(5), v(6),
                      tuple(v(4)))
        elif name == "dump":
            # dump ?s ?g ?c ?p ?q ?a ?u ?m
            run.dump(args[0], args[2], v(5), v(6))
        elif name == "stir":
            # stir ?s ?g ?c ?p ?q ?a ?u
            run.stir(args[0], args[2], resolve_pose(spec, args[2], v(3)), v(5), v(6))
        else:
            raise ActionFailed(f"the kitchen2d executor has no action {step.name!r}")

