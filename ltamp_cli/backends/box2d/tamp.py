"""Planning geometry of a Kitchen2D scene: poses, grasps, approaches, motions, skill setups.

Everything here is computed without simulating, from axis-aligned boxes (see
:mod:`.geometry`), and is what the kitchen2d domain's streams certify.

Values (all tuples of floats, so the planner can intern and print them):

* pose ``(x, y)``: the object's origin (bottom centre) standing upright;
* grasp ``(dx, dy)``: the gripper origin in the object's frame;
* conf ``(x, y)``: a gripper position with θ = 0 *above the reserved columns* (below);
* approach: a tuple of gripper positions from a conf down to where the hand acts;
* trajectory: a tuple of gripper positions from one conf to another;
* push approach: ``(conf, start, end)``: down from the conf to the pusher's start beside a
  block, then the push along the table (see :meth:`KitchenGeometry.push_setup`).

**Reserved columns.** Every place an object may stand (its home, the coaster, the spot
under the faucet) reserves the column above its footprint up to the object's height plus a
margin, whether or not the spot is occupied right now. Transit motions (OMPL RRT-Connect)
must avoid every column and the furniture, and hands act inside a column only along a
straight approach from a conf above it. A motion is therefore valid in *every* state, so
motion streams need no fluents, while two objects can only meet at the same spot, which the
placement collision test (:meth:`KitchenGeometry.cfree`) rules out.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ltamp_cli.backends.box2d.geometry import Box
from ltamp_cli.backends.box2d.scene import (
    CLEARANCE,
    SceneObject,
    SceneSpec,
    grasp_opening,
    object_top,
)
from ltamp_cli.backends.box2d.skills import pour as pour_skill
from ltamp_cli.backends.box2d.skills import push as push_skill
from ltamp_cli.backends.box2d.skills import scoop as scoop_skill
from ltamp_cli.motion import RRTConnectConfig, plan_rrt_connect

Point = tuple[float, float]
Rect = tuple[float, float, float, float]  # xmin, ymin, xmax, ymax

#: Finger opening while approaching a bar: narrow enough to pass between a cup's handle
#: and its wall.
APPROACH_OPENING = 0.4
COLUMN_MARGIN = 0.6
TRANSIT_MARGIN = 0.5
#: Length of bar the fingers must hold when *picking* (the skill trials start with the
#: object already in hand, so they accept a grasp at the very end of a bar; a real grasp
#: there tips the object over).
MIN_GRIP = 0.8
#: The push skill's pusher is a rectangle whose leading face is this far ahead of its
#: centre (skills/push.py); the kitchen pushes with the closed fingers, whose leading face
#: is put where the rectangle's would be.
PUSHER_HALF_DEPTH = push_skill.PushConfig().pusher_depth / 2
#: Radius of the push skill's round object.
PUSH_OBJECT_RADIUS = push_skill.PushConfig().object_radius
#: Pusher speed (units/s), as in the push skill's trials.
PUSH_SPEED = push_skill.PushConfig().speed
#: The learned push goal lies this far past the table edge: a control with g > 0 leaves the
#: block within 2 of it, so its centre ends at least 0.5 past the edge and it falls.
PUSH_PAST_EDGE = 2.5
#: The push skill's goal range (its context box is [-5, 5]^2).
PUSH_REACH = 5.0
#: Section test: the skill is learned seen from above; the kitchen shows the vertical
#: section through the block along the table, so only pushes that start in line with the
#: block (|ry| below this) and run mostly along the table (|sin angle| below this) apply.
SECTION_RY = 0.5
SECTION_SIN = 0.35


def _r(value: float) -> float:
    return round(float(value), 4)


def _corners(boxes: Sequence[Box], x: float, y: float, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    pts = []
    for b in boxes:
        for dx in (-b.hw, b.hw):
            for dy in (-b.hh, b.hh):
                px, py = b.cx + dx, b.cy + dy
                pts.append((x + c * px - s * py, y + s * px + c * py))
    return np.array(pts)


def empty_hand_path(approach: Sequence[Point]) -> tuple[Point, ...]:
    """How an empty hand reaches (or leaves) the grasp of an ``approach``: across at the
    conf's height, then straight down, since open fingers cannot slide onto a bar sideways."""
    conf, grasp = approach[0], approach[-1]
    above = (grasp[0], conf[1])
    return (conf, above, grasp) if above != conf else (conf, grasp)


@dataclass(frozen=True)
class Column:
    """Reserved space of one spot: ``rect`` in the world; ``spot`` names it."""

    spot: str
    rect: Rect


class KitchenGeometry:
    """Poses, grasps, collision checks and motions of one :class:`SceneSpec`."""

    def __init__(self, spec: SceneSpec, motion_time: float = 1.0) -> None:
        self.spec = spec
        lay = spec.layout
        self.top = lay.table_top
        self.motion_time = motion_time
        g = spec.gripper
        self.gripper_boxes = g.boxes(APPROACH_OPENING)
        cups = [o for o in spec.objects if o.kind == "cup"]
        self.spots: dict[str, tuple[Point, tuple[SceneObject, ...]]] = {}
        for item in spec.objects:
            self.spots[f"home:{item.name}"] = ((item.home, self.top), (item,))
        if cups:
            self.spots["coaster"] = ((lay.coaster_x, object_top(spec, "coaster")), tuple(cups))
            self.spots["faucet"] = ((lay.faucet_x, self.top), tuple(cups))
        self.columns = tuple(self._column(name, *value) for name, value in self.spots.items())
        self.ceiling = max(c.rect[3] for c in self.columns) if self.columns else self.top + 1
        # Surfaces sit a hair low so that objects resting on them do not count as hitting.
        sink = 0.05
        furniture: list[Rect] = [
            (lay.table_x0, self.top - lay.table_thickness, lay.table_x1, self.top - sink),
            (lay.faucet_x - 0.4, lay.faucet_y, lay.faucet_x + 0.4, lay.faucet_y + 0.6),
            (lay.coaster_x - lay.coaster_width / 2, self.top,
             lay.coaster_x + lay.coaster_width / 2, self.top + lay.coaster_height - sink),
        ]
        for x, width, height in spec.walls:
            furniture.append((x - width / 2, self.top, x + width / 2, self.top + height))
        for holder in spec.holders:
            for x0, x1 in holder.walls():
                furniture.append((x0, self.top, x1, self.top + holder.height))
        self.furniture = tuple(furniture)
        self.pusher_boxes = g.boxes(0.0)
        self.bounds = (
            np.array([-lay.width / 2 + 1, self.top + 0.3]),
            np.array([lay.width / 2 - 1, lay.height - 1]),
        )

    # --- spots and columns ---------------------------------------------------------------
    def _column(self, name: str, point: Point, items: tuple[SceneObject, ...]) -> Column:
        left = min(o.extent()[0] for o in items) - CLEARANCE
        right = max(o.extent()[1] for o in items) + CLEARANCE
        height = max(o.extent()[2] for o in items) + COLUMN_MARGIN
        x, y = point
        return Column(name, (x + left, y, x + right, y + height))

    def placements(self, name: str, region: str) -> list[Point]:
        """Poses of object ``name`` in ``region`` (``table``: its home; ``coaster``,
        ``faucet``: the one spot, for cups)."""
        item = self.spec.object(name)
        if region == "table":
            return [(_r(item.home), _r(self.top))]
        if region in ("coaster", "faucet") and item.kind == "cup" and region in self.spots:
            (x, y), _ = self.spots[region]
            return [(_r(x), _r(y))]
        return []

    def spot_of(self, pose: Point) -> str | None:
        for spot, ((x, y), _) in self.spots.items():
            if abs(x - pose[0]) < 1e-3 and abs(y - pose[1]) < 1e-3:
                return spot
        return None

    def region_of(self, pose: Point) -> str:
        spot = self.spot_of(pose)
        if spot is None or spot.startswith("home:"):
            return "table"
        return spot

    def cfree(self, a: str, pa: Point, b: str, pb: Point) -> bool:
        """Whether objects ``a`` at ``pa`` and ``b`` at ``pb`` (with clearance) do not overlap."""
        ra = self._footprint(self.spec.object(a), pa)
        rb = self._footprint(self.spec.object(b), pb)
        return ra[2] <= rb[0] or rb[2] <= ra[0]

    def _footprint(self, item: SceneObject, pose: Point) -> Rect:
        left, right, height = item.extent()
        return (pose[0] + left - CLEARANCE / 2, pose[1], pose[0] + right + CLEARANCE / 2,
                pose[1] + height)

    # --- collision checks ----------------------------------------------------------------
    def obstacles(self, exclude: Sequence[str] = ()) -> np.ndarray:
        """Obstacle rects ``(k, 4)``: furniture and every column not in ``exclude``."""
        rects = list(self.furniture)
        rects += [c.rect for c in self.columns if c.spot not in exclude]
        return np.array(rects, dtype=float)

    def hand_corners(self, held: SceneObject | None, grasp: Point | None, x: float, y: float,
                     angle: float = 0.0) -> np.ndarray:
        """Corners ``(m, 2)`` of the gripper (and the held object) with the gripper at
        ``(x, y, angle)``."""
        pts = [_corners(self.gripper_boxes, x, y, angle)]
        if held is not None and grasp is not None:
            c, s = math.cos(angle), math.sin(angle)
            ox, oy = -grasp[0], -grasp[1]
            pts.append(_corners(held.boxes(), x + c * ox - s * oy, y + s * ox + c * oy, angle))
        return np.concatenate(pts)

    def hand_edge_points(self, held: SceneObject, grasp: Point, x: float, y: float,
                         angle: float, per_edge: int = 12) -> np.ndarray:
        """Points ``(m, 2)`` along every edge of the held object's boxes (gripper at
        ``(x, y, angle)``), for a thin-wall contact test against axis-aligned boxes."""
        c, s = math.cos(angle), math.sin(angle)
        ox, oy = -grasp[0], -grasp[1]
        bx, by = x + c * ox - s * oy, y + s * ox + c * oy
        t = np.linspace(0.0, 1.0, per_edge)
        out = []
        for b in held.boxes():
            corners = np.array([[b.cx - b.hw, b.cy - b.hh], [b.cx + b.hw, b.cy - b.hh],
                                [b.cx + b.hw, b.cy + b.hh], [b.cx - b.hw, b.cy + b.hh]])
            for k in range(4):
                a, z = corners[k], corners[(k + 1) % 4]
                out.append(a[None, :] + t[:, None] * (z - a)[None, :])
        local = np.concatenate(out)
        return np.stack([bx + c * local[:, 0] - s * local[:, 1],
                         by + s * local[:, 0] + c * local[:, 1]], axis=1)

    def hand_rects(self, held: SceneObject | None, grasp: Point | None, x: float, y: float,
                   boxes: Sequence[Box] | None = None) -> np.ndarray:
        """Axis-aligned boxes ``(m, 4)`` of the upright gripper (``boxes``, default: open to
        :data:`APPROACH_OPENING`) and held object."""
        rects = [[x + b.cx - b.hw, y + b.cy - b.hh, x + b.cx + b.hw, y + b.cy + b.hh]
                 for b in (self.gripper_boxes if boxes is None else boxes)]
        if held is not None and grasp is not None:
            ox, oy = x - grasp[0], y - grasp[1]
            rects += [[ox + b.cx - b.hw, oy + b.cy - b.hh, ox + b.cx + b.hw, oy + b.cy + b.hh]
                      for b in held.boxes()]
        return np.array(rects, dtype=float)

    @staticmethod
    def overlaps(rects: np.ndarray, obstacles: np.ndarray, margin: float = 0.02) -> bool:
        if len(obstacles) == 0:
            return False
        a = rects[:, None, :]
        b = obstacles[None, :, :]
        sep = ((a[..., 2] + margin <= b[..., 0]) | (b[..., 2] + margin <= a[..., 0])
               | (a[..., 3] + margin <= b[..., 1]) | (b[..., 3] + margin <= a[..., 1]))
        return bool((~sep).any())

    def segment_free(self, held: SceneObject | None, grasp: Point | None,
                     path: Sequence[Point], exclude: Sequence[str] = (),
                     boxes: Sequence[Box] | None = None) -> bool:
        """Whether the upright hand (``boxes``: see :meth:`hand_rects`) moving along
        ``path`` (straight segments) stays clear."""
        obstacles = self.obstacles(exclude)
        for (x0, y0), (x1, y1) in itertools.pairwise(path):
            a = self.hand_rects(held, grasp, x0, y0, boxes)
            b = self.hand_rects(held, grasp, x1, y1, boxes)
            swept = np.concatenate([np.minimum(a[:, :2], b[:, :2]),
                                    np.maximum(a[:, 2:], b[:, 2:])], axis=1)
            if self.overlaps(swept, obstacles):
                return False
        return True

    def conf_height(self, held: SceneObject | None, grasp: Point | None) -> float:
        """Transit height of the gripper origin: everything it carries clears the columns."""
        hang = self.spec.gripper.tip
        if held is not None and grasp is not None:
            hang = max(hang, grasp[1])
        return _r(self.ceiling + TRANSIT_MARGIN + hang)

    # --- kinematics ----------------------------------------------------------------------
    def grip_ok(self, item: SceneObject, grasp: Point) -> bool:
        """Whether a real pick can take the bar at ``grasp``: the fingers hold at least
        ``MIN_GRIP`` of it and the palm stays above the bar's top end."""
        if item.kind in ("cup", "bowl"):
            bar_top = item.spec.height
        elif item.kind == "spoon":
            bar_top = item.spec.bowl_depth + item.spec.handle_length
        elif item.kind == "stirrer":
            bar_top = item.spec.length
        else:
            return True
        g = self.spec.gripper
        palm_bottom = grasp[1] + g.finger_length - g.tip
        return grasp[1] <= bar_top - MIN_GRIP and palm_bottom >= bar_top + 0.1

    def kinematics(self, name: str, pose: Point, grasp: Point
                   ) -> tuple[Point, tuple[Point, ...]] | None:
        """Conf above the spot and the approach of the hand *carrying* the object down to
        the grasp (see :func:`empty_hand_path` for the empty hand), or ``None`` if either
        is blocked. A cup goes under the faucet from the left."""
        item = self.spec.object(name)
        if not self.grip_ok(item, grasp):
            return None
        gx, gy = pose[0] + grasp[0], pose[1] + grasp[1]
        height = self.conf_height(item, grasp)
        spot = self.spot_of(pose)
        if spot == "faucet":
            lay = self.spec.layout
            right = pose[0] + item.extent()[1]
            shift = right - (lay.faucet_x - 0.4) + 0.3  # cup's right side left of the nozzle
            side = (_r(gx - shift), _r(gy))
            approach: tuple[Point, ...] = ((_r(side[0]), height), side, (_r(gx), _r(gy)))
        else:
            approach = ((_r(gx), height), (_r(gx), _r(gy)))
        exclude = [spot] if spot else []
        if not self.segment_free(item, grasp, approach[:-1], exclude):
            return None
        open_hand = self.spec.gripper.boxes(approach_opening(item))
        if not self.segment_free(None, None, empty_hand_path(approach), exclude, open_hand):
            return None
        return approach[0], approach

    def plan_motion(self, start: Point, goal: Point, held: str | None = None,
                    grasp: Point | None = None, seed: int = 0
                    ) -> tuple[Point, ...] | None:
        """A collision-free gripper path from ``start`` to ``goal`` (OMPL RRT-Connect over
        ``(x, y)``, checked against furniture and every reserved column)."""
        item = self.spec.object(held) if held is not None else None
        # The usual transit (up, across above every column, down) needs no search; RRT-Connect
        # handles the rest (walls, the faucet corridor, ...).
        level = max(start[1], goal[1])
        direct = (start, (start[0], level), (goal[0], level), goal)
        if self.segment_free(item, grasp, direct):
            return tuple(p for k, p in enumerate(direct) if k == 0 or p != direct[k - 1])
        obstacles = self.obstacles()

        def valid(q: np.ndarray) -> bool:
            return not self.overlaps(self.hand_rects(item, grasp, float(q[0]), float(q[1])),
                                     obstacles)

        plan = plan_rrt_connect(
            np.array(start, dtype=float), np.array(goal, dtype=float), *self.bounds, valid,
            RRTConnectConfig(time_limit=self.motion_time, seed=seed, resolution=0.1,
                             shortcut_iterations=30),
        )
        if plan.path is None:
            return None
        return tuple((_r(x), _r(y)) for x, y in plan.path)

    # --- skills --------------------------------------------------------------------------
    def swing_free(self, held: SceneObject, grasp: Point, pivot: Point, angles: np.ndarray,
                   pivot_in_hand: Point, exclude: Sequence[str]) -> bool:
        """Whether the hand rotated about ``pivot`` through ``angles`` stays clear.

        ``pivot_in_hand`` is the pivot in the gripper frame; the gripper moves so that the
        pivot stays fixed in the world.
        """
        obstacles = self.obstacles(exclude)
        px, py = pivot_in_hand
        for angle in angles:
            c, s = math.cos(angle), math.sin(angle)
            gx = pivot[0] - (c * px - s * py)
            gy = pivot[1] - (s * px + c * py)
            pts = self.hand_corners(held, grasp, gx, gy, float(angle))
            rect = np.array([[pts[:, 0].min(), pts[:, 1].min(), pts[:, 0].max(),
                              pts[:, 1].max()]])
            if self.overlaps(rect, obstacles):
                return False
        return True

    def pour_start(self, target: str, pose: Point, control: Sequence[float]) -> Point:
        """Gripper origin at the start of a pour into ``target`` at ``pose``."""
        spec = self.spec.object(target).spec
        return (_r(pose[0] + control[1]), _r(pose[1] + spec.height + control[2]))

    def pour_setup(self, source: str, target: str, pose: Point, control: Sequence[float]
                   ) -> tuple[Point, Point, tuple[Point, ...]] | None:
        """Grasp, conf and approach of a pour (control: the pour skill's 4 numbers), or
        ``None`` if the descent or the tilt would hit something outside the target's spot.
        The target cup itself is the learned skill's business (its validity test)."""
        item = self.spec.object(source)
        grasp = (_r(item.spec.handle_x), _r(item.spec.grasp_height(float(control[0]))))
        if not self.grip_ok(item, grasp):
            return None
        start = self.pour_start(target, pose, control)
        # A pour starting above the transit height starts from a conf at its own height
        # (the transit motions go up and over to it): in low scenes (Tasks II and III,
        # cups ~3.5 high) about half of the skill's successful trials start that high.
        height = max(self.conf_height(item, grasp), start[1])
        conf = (start[0], height)
        approach = (conf, start)
        spot = self.spot_of(pose)
        exclude = [spot] if spot else []
        if not self.segment_free(item, grasp, approach, exclude):
            return None
        # Tilt about the grasp point (the gripper origin) up to dangle, towards the target
        # (the skill's sense: sign(rel_x)).
        angles = pour_skill.tilt_sign(float(control[1])) * np.linspace(0.0, float(control[3]), 24)
        if not self.swing_free(item, grasp, start, angles, (0.0, 0.0), [*exclude, "table"]):
            return None
        # The pour score does not mind shoving the target cup aside; a plan does (the cup
        # would leave its spot): the tilting cup and hand must not touch the target's walls.
        target_item = self.spec.object(target)
        walls = np.array([[pose[0] + b.cx - b.hw - 0.05, pose[1] + b.cy - b.hh - 0.05,
                           pose[0] + b.cx + b.hw + 0.05, pose[1] + b.cy + b.hh + 0.05]
                          for b in target_item.boxes()])
        for angle in angles:
            points = self.hand_edge_points(item, grasp, start[0], start[1], float(angle))
            inside = ((points[:, None, 0] > walls[None, :, 0])
                      & (points[:, None, 0] < walls[None, :, 2])
                      & (points[:, None, 1] > walls[None, :, 1])
                      & (points[:, None, 1] < walls[None, :, 3]))
            if inside.any():
                return None
        return grasp, conf, approach

    def scoop_setup(self, spoon: str, bowl: str, pose: Point, control: Sequence[float]
                    ) -> tuple[Point, Point, tuple[Point, ...]] | None:
        """Grasp, conf and approach (down to the scoop's entry point) of a scoop."""
        item = self.spec.object(spoon)
        cup = self.spec.object(bowl).spec
        config = scoop_skill.ScoopConfig()
        context = np.array([cup.width, cup.height])
        path = scoop_skill.waypoints(context, np.asarray(control, dtype=float), config)
        grasp = (_r(item.spec.handle_x), _r(scoop_skill.grasp_height(config, float(control[0]))))
        if not self.grip_ok(item, grasp):
            return None
        entry = (_r(pose[0] + path[0, 0] + grasp[0]), _r(pose[1] - self.top + path[0, 1]
                                                          + grasp[1]))
        exit_ = (_r(pose[0] + path[-1, 0] + grasp[0]), _r(pose[1] - self.top + path[-1, 1]
                                                           + grasp[1]))
        height = self.conf_height(item, grasp)
        conf = (entry[0], height)
        spot = self.spot_of(pose)
        exclude = [spot] if spot else []
        if not self.segment_free(item, grasp, (conf, entry), exclude):
            return None
        if not self.segment_free(item, grasp, (exit_, (exit_[0], height)), exclude):
            return None
        return grasp, conf, (conf, entry)

    def scoop_exit_conf(self, spoon: str, bowl: str, pose: Point, control: Sequence[float],
                        grasp: Point) -> Point:
        cup = self.spec.object(bowl).spec
        path = scoop_skill.waypoints(np.array([cup.width, cup.height]),
                                     np.asarray(control, dtype=float), scoop_skill.ScoopConfig())
        return (_r(pose[0] + path[-1, 0] + grasp[0]), self.conf_height(self.spec.object(spoon),
                                                                       grasp))

    def dump_setups(self, spoon: str, grasp: Point, target: str, pose: Point
                    ) -> list[tuple[Point, tuple[Point, ...], tuple[float, ...]]]:
        """Candidate dumps of a spoon over a cup: ``(conf, approach, control)`` with control
        ``(bowl_x, bowl_y, angle)``: the spoon bowl's centre is brought to ``(bowl_x,
        bowl_y)`` and turned clockwise by ``-angle`` about that point, so the mouth faces
        down-right and the handle stays above the rim."""
        item = self.spec.object(spoon)
        cup = self.spec.object(target).spec
        sp = item.spec
        rim = pose[1] + cup.height
        spot = self.spot_of(pose)
        exclude = [spot] if spot else []
        out = []
        height = self.conf_height(item, grasp)
        angle = -2.1
        angles = np.linspace(0.0, angle, 12)
        centre_in_hand = (-grasp[0], sp.bowl_depth / 2 - grasp[1])
        rim_rect = (pose[0] - cup.width / 2 - 1.0, pose[1], pose[0] + cup.width / 2 + 0.2,
                    rim + 0.3)
        for frac in (0.3, 0.5, 0.1):
            for lift in (1.5, 2.5, 3.5, 4.5):
                bowl = (_r(pose[0] - frac * cup.inner_width / 2), _r(rim + lift))
                start = (_r(bowl[0] - centre_in_hand[0]), _r(bowl[1] - centre_in_hand[1]))
                if start[1] > height:
                    continue
                approach = ((start[0], height), start)
                if not self.segment_free(item, grasp, approach, exclude):
                    continue
                if not self.swing_free(item, grasp, bowl, angles, centre_in_hand, exclude):
                    continue
                if self._swing_clear_of(item, grasp, bowl, angles, centre_in_hand, rim_rect):
                    out.append(((start[0], height), approach, (bowl[0], bowl[1], angle)))
                    break
        return out

    def _swing_clear_of(self, held: SceneObject, grasp: Point, pivot: Point,
                        angles: np.ndarray, pivot_in_hand: Point, rect: Rect) -> bool:
        px, py = pivot_in_hand
        for angle in angles:
            c, s = math.cos(angle), math.sin(angle)
            gx = pivot[0] - (c * px - s * py)
            gy = pivot[1] - (s * px + c * py)
            pts = self.hand_corners(held, grasp, gx, gy, float(angle))
            inside = ((pts[:, 0] > rect[0]) & (pts[:, 0] < rect[2]) & (pts[:, 1] > rect[1])
                      & (pts[:, 1] < rect[3]))
            if inside.any() or (pts[:, 1].min() < rect[3] and self._spans(pts, rect)):
                return False
        return True

    @staticmethod
    def _spans(pts: np.ndarray, rect: Rect) -> bool:
        """Whether a convex-ish hull of ``pts`` below the rect's top crosses it in x."""
        low = pts[pts[:, 1] < rect[3]]
        return bool(len(low)) and low[:, 0].max() > rect[0] and low[:, 0].min() < rect[2]

    def stir_setup(self, stirrer: str, grasp: Point, target: str, pose: Point
                   ) -> tuple[Point, tuple[Point, ...], tuple[float, ...]] | None:
        """Conf, approach and control ``(depth_y, amplitude, cycles)`` of a stir: the paddle
        goes down to just above the cup floor and sweeps ``±amplitude`` ``cycles`` times."""
        item = self.spec.object(stirrer)
        cup = self.spec.object(target).spec
        # A wide berth from the walls: grains squeezed between the (unstoppable) paddle and
        # a wall are shot out of the cup by the solver.
        amplitude = max(0.0, cup.inner_width / 2 - item.spec.paddle_width / 2 - 0.5)
        bottom = pose[1] + cup.wall + 0.25
        hand = (_r(pose[0] + grasp[0]), _r(bottom + grasp[1]))
        height = self.conf_height(item, grasp)
        conf = (hand[0], height)
        spot = self.spot_of(pose)
        exclude = [spot] if spot else []
        if not self.segment_free(item, grasp, (conf, hand), exclude):
            return None
        return conf, (conf, hand), (_r(bottom), _r(amplitude), 3.0)

    # --- push ----------------------------------------------------------------------------
    def edge_x(self, edge: str) -> float:
        """x of a table edge named ``left...`` or ``right...`` (e.g. ``left_edge``)."""
        lay = self.spec.layout
        if edge.startswith("left"):
            return lay.table_x0
        if edge.startswith("right"):
            return lay.table_x1
        raise ValueError(f"not a table edge: {edge!r} (expected a name starting with "
                         f"left or right)")

    def push_height(self, name: str, pose: Point) -> float:
        """Gripper origin height while pushing block ``name``: fingertips at half its size,
        above any curb beside it."""
        return _r(pose[1] + self.spec.object(name).spec.size / 2 + self.spec.gripper.tip)

    def push_context(self, name: str, pose: Point, edge: str) -> np.ndarray | None:
        """The push skill's context ``(goal_x, goal_y)`` (relative to the block) for pushing
        ``name`` off ``edge``, or ``None`` if that goal is beyond the skill's reach."""
        x_edge = self.edge_x(edge)
        distance = abs(x_edge - pose[0]) + PUSH_PAST_EDGE
        if distance > PUSH_REACH:
            return None
        return np.array([math.copysign(distance, x_edge - pose[0]), 0.0])

    def push_path_clear(self, name: str, pose: Point, edge: str) -> bool:
        """Whether the block can slide from ``pose`` to ``edge`` without meeting furniture
        (a curb or wall on that side): independent of the control."""
        size = self.spec.object(name).spec.size
        x_edge = self.edge_x(edge)
        x0, x1 = sorted((pose[0] - size / 2, pose[0] + size / 2))
        swept = np.array([[min(x0, x_edge), pose[1] + 0.05, max(x1, x_edge),
                           pose[1] + size]])
        return not self.overlaps(swept, np.array(self.furniture[1:]))

    def push_offset(self, name: str) -> float:
        """How far ahead of the skill's pusher centre ``rx`` the hand's centre goes, so that
        the gap from the hand's leading face to block ``name`` is the skill's gap from its
        pusher's leading face to its disc (the learned durations then reach the block)."""
        half = self.spec.gripper.finger_width  # closed fingers: two finger widths wide
        size = self.spec.object(name).spec.size
        return PUSHER_HALF_DEPTH - half + PUSH_OBJECT_RADIUS - size / 2

    def push_setup(self, name: str, pose: Point, edge: str, control: Sequence[float]
                   ) -> tuple[Point, tuple[Point, Point, Point]] | None:
        """Conf and push approach ``(conf, start, end)`` of a push of block ``name`` off
        ``edge`` with the push skill's control ``(rx, ry, angle, duration)``.

        The closed gripper goes down beside the block (its leading face as far from the
        block as the skill's pusher's from its disc, see :meth:`push_offset`) and moves along
        the table by the x part of the skill's push,
        ``PUSH_SPEED · duration · cos(angle)``. ``None`` if the push does not run towards
        the edge or the gripper would hit furniture (outside the block's own column).
        """
        rx, _ry, angle, duration = (float(v) for v in control)
        direction = math.copysign(1.0, self.edge_x(edge) - pose[0])
        travel = PUSH_SPEED * duration * math.cos(angle)
        if direction * travel <= 0 or direction * rx >= 0:
            return None
        start = (_r(pose[0] + rx + direction * self.push_offset(name)),
                 self.push_height(name, pose))
        end = (_r(start[0] + travel), start[1])
        conf = (start[0], self.conf_height(None, None))
        spot = self.spot_of(pose)
        exclude = [spot] if spot else []
        path = (conf, start, end, (end[0], conf[1]))
        if not self.segment_free(None, None, path, exclude, self.pusher_boxes):
            return None
        return conf, (conf, start, end)

    def distance(self, a: Point, b: Point) -> float:
        return _r(math.hypot(a[0] - b[0], a[1] - b[1]) + 1.0)

    def opening(self, name: str) -> float:
        return grasp_opening(self.spec.object(name))


def approach_opening(item: SceneObject) -> float:
    """Finger opening of an empty hand going down to grasp ``item``: narrow for bars
    (handles, rods), wide enough to straddle a block."""
    if item.kind == "block":
        return min(item.spec.size + 0.2, 0.8)
    return APPROACH_OPENING


def section_mask(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
    """Push controls ``(n, 4)`` that apply in the kitchen's section for a goal ``context``
    ``(goal_x, 0)``: the pusher starts behind the block in line with it and runs mostly
    along the table towards the goal (see :data:`SECTION_RY`)."""
    direction = np.sign(context[0])
    rx, ry, angle = controls[:, 0], controls[:, 1], controls[:, 2]
    return ((direction * rx < 0) & (np.abs(ry) <= SECTION_RY)
            & (np.abs(np.sin(angle)) <= SECTION_SIN) & (direction * np.cos(angle) > 0))
