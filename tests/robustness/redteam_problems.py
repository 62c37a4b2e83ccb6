"""Three small PDDLStream-style problems written from scratch for the red-team tests.

* ``rover``: a rover on a plane with a discrete battery drives between sampled positions;
  the route stream is a ``:fluents`` stream (it sees which debris is still on the ground),
  drives cost their length (``:function``), clearing debris costs 1.
* ``conveyor``: boxes are placed on a 1-D belt at continuous positions; a placement needs
  a negated collision test against every placed box (a ``forall`` precondition) and the
  goal is a ``forall`` over boxes.
* ``sensors``: a sensor network; a ``:rule`` and derived predicates decide what is
  covered, and a wild stream (no ``:certified``) reports extra facts it discovers.

Each builder writes its PDDL files into ``folder`` (so errors name real files) and returns
``(problem, check)``: ``check(plan)`` raises ``AssertionError`` unless the plan, replayed on
the Python values, reaches the goal. The YAML route writes the same files plus a
``streams.py`` bindings module and a ``problem.yaml``.
"""

from __future__ import annotations

import textwrap
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.pddlstream import (
    And,
    ForAll,
    Imply,
    PDDLProblem,
    WildOutput,
    from_fn,
    from_gen_fn,
    from_test,
    read,
)

Check = Callable[[Sequence[Any]], None]


def write(folder: Path, name: str, text: str) -> str:
    path = folder / name
    path.write_text(textwrap.dedent(text).lstrip())
    return read(path)


# --------------------------------------------------------------------------- rover
ROVER_DOMAIN = """
(define (domain rover-charge)
  (:requirements :strips :negative-preconditions :action-costs)
  (:predicates (Conf ?q) (At ?q) (Route ?q1 ?q2 ?t) (Level ?l) (Battery ?l) (Down ?l1 ?l2)
               (Full ?l) (Charger ?q) (Rock ?r) (Near ?r ?q) (Analyzed ?r)
               (Debris ?d) (OnGround ?d) (NearDebris ?d ?q) (Traj ?t))
  (:functions (Length ?t))
  (:action drive
    :parameters (?q1 ?q2 ?t ?l1 ?l2)
    :precondition (and (Route ?q1 ?q2 ?t) (At ?q1) (Battery ?l1) (Down ?l1 ?l2))
    :effect (and (At ?q2) (not (At ?q1)) (Battery ?l2) (not (Battery ?l1))
                 (increase (total-cost) (Length ?t))))
  (:action charge
    :parameters (?q ?l1 ?l2)
    :precondition (and (At ?q) (Charger ?q) (Battery ?l1) (Full ?l2))
    :effect (and (Battery ?l2) (not (Battery ?l1)) (increase (total-cost) 1)))
  (:action clear
    :parameters (?d ?q)
    :precondition (and (NearDebris ?d ?q) (At ?q) (OnGround ?d))
    :effect (and (not (OnGround ?d)) (increase (total-cost) 1)))
  (:action analyze
    :parameters (?r ?q)
    :precondition (and (Near ?r ?q) (At ?q))
    :effect (and (Analyzed ?r) (increase (total-cost) 1))))
"""

ROVER_STREAMS = """
(define (stream rover-charge)
  (:stream sample-near
    :inputs (?r) :domain (Rock ?r)
    :outputs (?q) :certified (and (Conf ?q) (Near ?r ?q)))
  (:stream sample-debris-spot
    :inputs (?d) :domain (Debris ?d)
    :outputs (?q) :certified (and (Conf ?q) (NearDebris ?d ?q)))
  (:stream plan-route
    :inputs (?q1 ?q2) :domain (and (Conf ?q1) (Conf ?q2))
    :fluents (OnGround)
    :outputs (?t) :certified (and (Traj ?t) (Route ?q1 ?q2 ?t)))
  (:function (Length ?t) (Traj ?t)))
"""

# The wall of debris "d1" lies across x = 5 for |y| < 3: a route crossing it is refused
# while d1 is on the ground. The rock lies beyond it; the charger is at the start, where
# the battery has one drive left (a full one has three): charge, drive to the debris, clear
# it, drive to the rock, analyze, drive straight home (through the cleared wall).
ROVER_ROCKS = {"rock1": np.array([8.0, 0.0])}
ROVER_DEBRIS = {"d1": np.array([4.0, 0.0])}
ROVER_MAX_DRIVE = 9.0


def _crosses_wall(q1: np.ndarray, q2: np.ndarray) -> bool:
    x1, x2 = float(q1[0]), float(q2[0])
    if (x1 - 5.0) * (x2 - 5.0) > 0:
        return False
    if x1 == x2:
        return abs(float(q1[1])) < 3.0
    t = (5.0 - x1) / (x2 - x1)
    y = float(q1[1]) + t * (float(q2[1]) - float(q1[1]))
    return abs(y) < 3.0


def rover_samplers(seed: int = 0) -> dict[str, Callable[..., Any]]:
    rng = np.random.default_rng(seed)

    def sample_near(rock: str) -> Iterator[tuple[np.ndarray]]:
        centre = ROVER_ROCKS[rock]
        while True:
            yield (np.round(centre + rng.uniform(-0.5, 0.5, size=2), 3),)

    def sample_debris_spot(debris: str) -> Iterator[tuple[np.ndarray]]:
        centre = ROVER_DEBRIS[debris]
        while True:
            yield (np.round(centre + rng.uniform(-0.5, 0.5, size=2), 3),)

    def plan_route(q1: np.ndarray, q2: np.ndarray, fluents: Sequence[tuple[Any, ...]] = ()
                   ) -> tuple[tuple[Any, ...]] | None:
        on_ground = {fact[1] for fact in fluents if fact[0].lower() == "onground"}
        length = float(np.linalg.norm(np.asarray(q2) - np.asarray(q1)))
        if length > ROVER_MAX_DRIVE:
            return None
        if "d1" in on_ground and _crosses_wall(q1, q2):
            return None
        return (("route", tuple(np.asarray(q1).tolist()), tuple(np.asarray(q2).tolist()),
                 round(length, 6)),)

    def route_length(route: tuple[Any, ...]) -> float:
        return float(route[3])

    return {"sample-near": sample_near, "sample-debris-spot": sample_debris_spot,
            "plan-route": plan_route, "Length": route_length}


def rover_problem(folder: Path, seed: int = 0) -> tuple[PDDLProblem, Check]:
    samplers = rover_samplers(seed)
    stream_map = {"sample-near": from_gen_fn(samplers["sample-near"]),
                  "sample-debris-spot": from_gen_fn(samplers["sample-debris-spot"]),
                  "plan-route": from_fn(samplers["plan-route"]),
                  "length": samplers["Length"]}
    home = np.array([0.0, 0.0])
    init = [("Conf", home), ("At", home), ("Charger", home), ("Rock", "rock1"),
            ("Debris", "d1"), ("OnGround", "d1"),
            ("Level", "l0"), ("Level", "l1"), ("Level", "l2"), ("Level", "l3"),
            ("Battery", "l1"), ("Down", "l3", "l2"), ("Down", "l2", "l1"), ("Down", "l1", "l0"),
            ("Full", "l3")]
    goal = And(("Analyzed", "rock1"), ("At", home))
    problem = PDDLProblem(write(folder, "rover_domain.pddl", ROVER_DOMAIN), {},
                          write(folder, "rover_stream.pddl", ROVER_STREAMS), stream_map,
                          init, goal)

    def check(plan: Sequence[Any]) -> None:
        at, battery, debris_down, analyzed = home, 1, True, False
        for action in plan:
            name, args = action.name, action.args
            if name == "drive":
                q1, q2, route = args[0], args[1], args[2]
                assert np.array_equal(np.asarray(q1), np.asarray(at)), (q1, at)
                assert battery >= 1, "drove on an empty battery"
                length = float(np.linalg.norm(np.asarray(q2) - np.asarray(q1)))
                assert length <= ROVER_MAX_DRIVE + 1e-9
                assert not (debris_down and _crosses_wall(q1, q2)), "drove through debris"
                assert route[3] == round(length, 6)
                at, battery = q2, battery - 1
            elif name == "charge":
                assert np.array_equal(np.asarray(at), home)
                battery = 3
            elif name == "clear":
                assert float(np.linalg.norm(np.asarray(at) - ROVER_DEBRIS["d1"])) <= 0.75
                debris_down = False
            elif name == "analyze":
                assert float(np.linalg.norm(np.asarray(at) - ROVER_ROCKS["rock1"])) <= 0.75
                analyzed = True
        assert analyzed and np.array_equal(np.asarray(at), home)

    return problem, check


# --------------------------------------------------------------------------- conveyor
CONVEYOR_DOMAIN = """
(define (domain conveyor)
  (:requirements :strips :negative-preconditions :universal-preconditions
                 :disjunctive-preconditions)
  (:predicates (Box ?b) (Pos ?b ?x) (Waiting ?b) (OnBelt ?b) (AtPos ?b ?x)
               (Collide ?b ?x ?b2 ?x2) (Checked ?b))
  (:action place
    :parameters (?b ?x)
    :precondition (and (Pos ?b ?x) (Waiting ?b)
                       (forall (?b2 ?x2) (imply (AtPos ?b2 ?x2)
                                                (not (Collide ?b ?x ?b2 ?x2)))))
    :effect (and (OnBelt ?b) (AtPos ?b ?x) (not (Waiting ?b))))
  (:action inspect
    :parameters (?b ?x)
    :precondition (and (AtPos ?b ?x) (OnBelt ?b))
    :effect (Checked ?b)))
"""

CONVEYOR_STREAMS = """
(define (stream conveyor)
  (:stream sample-pos
    :inputs (?b) :domain (Box ?b)
    :outputs (?x) :certified (Pos ?b ?x))
  (:stream test-collide
    :inputs (?b ?x ?b2 ?x2) :domain (and (Pos ?b ?x) (Pos ?b2 ?x2))
    :certified (Collide ?b ?x ?b2 ?x2)))
"""

# Belt [0, 3]; box widths; two boxes must both fit without overlapping.
CONVEYOR_BELT = (0.0, 3.0)
CONVEYOR_WIDTH = {"b1": 1.2, "b2": 1.4, "b3": 0.3}


def conveyor_samplers(seed: int = 0) -> dict[str, Callable[..., Any]]:
    rng = np.random.default_rng(seed)

    def sample_pos(box: str) -> Iterator[tuple[float]]:
        half = CONVEYOR_WIDTH[box] / 2
        while True:
            yield (round(float(rng.uniform(CONVEYOR_BELT[0] + half,
                                           CONVEYOR_BELT[1] - half)), 3),)

    def collide(b: str, x: float, b2: str, x2: float) -> bool:
        if b == b2:
            return False
        return abs(x - x2) < (CONVEYOR_WIDTH[b] + CONVEYOR_WIDTH[b2]) / 2

    return {"sample-pos": sample_pos, "test-collide": collide}


def conveyor_problem(folder: Path, seed: int = 0,
                     boxes: Sequence[str] = ("b1", "b2")) -> tuple[PDDLProblem, Check]:
    samplers = conveyor_samplers(seed)
    stream_map = {"sample-pos": from_gen_fn(samplers["sample-pos"]),
                  "test-collide": from_test(samplers["test-collide"])}
    init: list[tuple[Any, ...]] = []
    for box in boxes:
        init += [("Box", box), ("Waiting", box)]
    goal = ForAll(["?b"], Imply(("Box", "?b"), ("Checked", "?b")))
    problem = PDDLProblem(write(folder, "conveyor_domain.pddl", CONVEYOR_DOMAIN), {},
                          write(folder, "conveyor_stream.pddl", CONVEYOR_STREAMS),
                          stream_map, init, goal)

    def check(plan: Sequence[Any]) -> None:
        placed: dict[str, float] = {}
        checked = set()
        for action in plan:
            if action.name == "place":
                box, x = action.args
                half = CONVEYOR_WIDTH[box] / 2
                assert CONVEYOR_BELT[0] + half <= x <= CONVEYOR_BELT[1] - half
                assert box not in placed
                for other, x2 in placed.items():
                    assert not samplers["test-collide"](box, x, other, x2), (box, x, other)
                placed[box] = x
            elif action.name == "inspect":
                assert action.args[0] in placed
                checked.add(action.args[0])
        assert checked == set(boxes)

    return problem, check


# --------------------------------------------------------------------------- sensors
SENSORS_DOMAIN = """
(define (domain sensors)
  (:requirements :strips :derived-predicates :negative-preconditions :existential-preconditions)
  (:predicates (Room ?r) (Sensor ?s) (Mount ?s ?m) (Installed ?s ?m) (Carrying ?s)
               (Covered ?r) (Sees ?m ?r) (Powered ?m) (Safe ?m) (Reported ?r))
  (:derived (Covered ?r)
    (exists (?s ?m) (and (Installed ?s ?m) (Sees ?m ?r) (Safe ?m))))
  (:action install
    :parameters (?s ?m)
    :precondition (and (Mount ?s ?m) (Carrying ?s))
    :effect (and (Installed ?s ?m) (not (Carrying ?s))))
  (:action report
    :parameters (?r)
    :precondition (and (Room ?r) (Covered ?r))
    :effect (Reported ?r)))
"""

# sample-mount certifies where a sensor may be mounted; survey (no :certified) reports wild
# (Sees ?m ?r) facts; a :rule makes every powered mount Safe.
SENSORS_STREAMS = """
(define (stream sensors)
  (:stream sample-mount
    :inputs (?s) :domain (Sensor ?s)
    :outputs (?m) :certified (and (Mount ?s ?m) (Powered ?m)))
  (:stream survey
    :inputs (?s ?m) :domain (Mount ?s ?m)
    :outputs ())
  (:rule :inputs (?m) :domain (Powered ?m) :certified (Safe ?m)))
"""

SENSORS_ROOMS = {"kitchen": (0.0, 2.0), "hall": (2.0, 4.0)}
SENSORS_RANGE = 1.0


def sensors_samplers(seed: int = 0, *, wild: Callable[..., Any] = WildOutput
                     ) -> dict[str, Callable[..., Any]]:
    rng = np.random.default_rng(seed)

    def sample_mount(sensor: str) -> Iterator[tuple[float]]:
        while True:
            yield (round(float(rng.uniform(0.0, 4.0)), 3),)

    def survey(sensor: str, mount: float) -> Iterator[Any]:
        facts = [("Sees", mount, room) for room, (lo, hi) in SENSORS_ROOMS.items()
                 if lo - SENSORS_RANGE / 2 <= mount <= hi + SENSORS_RANGE / 2
                 and lo <= mount <= hi]
        yield wild((), facts)

    return {"sample-mount": sample_mount, "survey": survey}


def sensors_problem(folder: Path, seed: int = 0) -> tuple[PDDLProblem, Check]:
    samplers = sensors_samplers(seed)
    stream_map = {"sample-mount": from_gen_fn(samplers["sample-mount"]),
                  "survey": samplers["survey"]}
    init = [("Room", "kitchen"), ("Room", "hall"), ("Sensor", "s1"), ("Sensor", "s2"),
            ("Carrying", "s1"), ("Carrying", "s2")]
    goal = And(("Reported", "kitchen"), ("Reported", "hall"))
    problem = PDDLProblem(write(folder, "sensors_domain.pddl", SENSORS_DOMAIN), {},
                          write(folder, "sensors_stream.pddl", SENSORS_STREAMS), stream_map,
                          init, goal)

    def check(plan: Sequence[Any]) -> None:
        mounts: list[float] = []
        reported = set()
        for action in plan:
            if action.name == "install":
                mounts.append(float(action.args[1]))
            elif action.name == "report":
                room = action.args[0]
                lo, hi = SENSORS_ROOMS[room]
                assert any(lo <= m <= hi for m in mounts), (room, mounts)
                reported.add(room)
        assert reported == {"kitchen", "hall"}

    return problem, check


BUILDERS: dict[str, Callable[..., tuple[PDDLProblem, Check]]] = {
    "rover": rover_problem, "conveyor": conveyor_problem, "sensors": sensors_problem}


# --------------------------------------------------------------------------- YAML route
_BINDINGS = '''"""Bindings of the red-team problem {name!r}: the same samplers as the Python API."""

import sys

from ltamp_cli.planner.streams import WildOutput

sys.path.insert(0, {here!r})
import redteam_problems as problems  # noqa: E402


def make_streams(world, rng):
    seed = int(rng.integers(0, 2**31))
    samplers = problems.{name}_samplers(seed{extra})
    if {name!r} == "sensors":  # a test-shaped stream returns its WildOutput (never yields)
        survey = samplers["survey"]
        samplers["survey"] = lambda sensor, mount: next(survey(sensor, mount))
    return samplers  # the rover's cost function stays keyed 'Length' (case-insensitive)
'''

_YAML = {
    "rover": """name: rover-yaml
domain: domain
bindings: streams.py
objects:
  home: [0.0, 0.0]
  rock1: null
  d1: null
  l0: null
  l1: null
  l2: null
  l3: null
init: ["(Conf home)", "(At home)", "(Charger home)", "(Rock rock1)", "(Debris d1)",
       "(OnGround d1)", "(Level l0)", "(Level l1)", "(Level l2)", "(Level l3)",
       "(Battery l1)", "(Down l3 l2)", "(Down l2 l1)", "(Down l1 l0)", "(Full l3)"]
goal: (and (Analyzed rock1) (At home))
""",
    "conveyor": """name: conveyor-yaml
domain: domain
bindings: streams.py
objects: {b1: null, b2: null}
init: ["(Box b1)", "(Waiting b1)", "(Box b2)", "(Waiting b2)"]
goal: (forall (?b) (imply (Box ?b) (Checked ?b)))
""",
    "sensors": """name: sensors-yaml
domain: domain
bindings: streams.py
objects: {kitchen: null, hall: null, s1: null, s2: null}
init: ["(Room kitchen)", "(Room hall)", "(Sensor s1)", "(Sensor s2)", "(Carrying s1)",
       "(Carrying s2)"]
goal: (and (Reported kitchen) (Reported hall))
""",
}

_FILES = {"rover": (ROVER_DOMAIN, ROVER_STREAMS), "conveyor": (CONVEYOR_DOMAIN, CONVEYOR_STREAMS),
          "sensors": (SENSORS_DOMAIN, SENSORS_STREAMS)}


def write_yaml_problem(folder: Path, name: str) -> Path:
    """Write ``name``'s domain folder, bindings module and ``problem.yaml`` under ``folder``
    (the ``ltamp solve`` route); returns the problem file."""
    domain_text, stream_text = _FILES[name]
    (folder / "domain").mkdir(parents=True, exist_ok=True)
    write(folder / "domain", "domain.pddl", domain_text)
    write(folder / "domain", "stream.pddl", stream_text)
    extra = ", wild=WildOutput" if name == "sensors" else ""
    (folder / "streams.py").write_text(_BINDINGS.format(
        name=name, here=str(Path(__file__).resolve().parent), extra=extra))
    problem = folder / "problem.yaml"
    problem.write_text(_YAML[name])
    return problem
