"""Small PDDLStream-style problems written for these tests (none copied from PDDLStream).

Each builder returns a :class:`~ltamp_cli.pddlstream.PDDLProblem` whose objects are Python
values; the stream files are written to ``folder`` so that errors point at real files.
"""

from __future__ import annotations

import textwrap
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.pddlstream import (
    And,
    Exists,
    ForAll,
    Imply,
    Not,
    Or,
    PDDLProblem,
    StreamInfo,
    WildOutput,
    from_fn,
    from_gen_fn,
    from_list_fn,
    from_sampler,
    from_test,
    read,
)


def write(folder: Path, name: str, text: str) -> str:
    """Write a PDDL file and read it back the PDDLStream way (the text knows its path)."""
    path = folder / name
    path.write_text(textwrap.dedent(text).lstrip())
    return read(path)


# A collector: a gripper moves between configurations (numpy arrays) computed by inverse
# kinematics from item poses and collects items (dicts: unhashable) whose poses are arrays.
REACH_DOMAIN = """
(define (domain Reach)
  (:requirements :strips)
  (:predicates (Conf ?q) (AtConf ?q) (Item ?i) (Pose ?i ?p) (AtPose ?i ?p) (Kin ?i ?p ?q)
               (Holding ?i) (HandEmpty))
  (:functions (Distance ?q1 ?q2))
  (:action move
    :parameters (?q1 ?q2)
    :precondition (and (Conf ?q1) (Conf ?q2) (AtConf ?q1))
    :effect (and (AtConf ?q2) (not (AtConf ?q1)) (increase (total-cost) (Distance ?q1 ?q2))))
  (:action pick
    :parameters (?i ?p ?q)
    :precondition (and (Kin ?i ?p ?q) (AtPose ?i ?p) (AtConf ?q) (HandEmpty) (Reachable ?q))
    :effect (and (Holding ?i) (not (AtPose ?i ?p)) (increase (total-cost) 1))))
"""

# PDDL names are case-insensitive: the stream file and the bindings use other cases.
REACH_STREAMS = """
(define (stream reach)
  (:stream Inverse-Kinematics
    :inputs (?i ?p) :domain (POSE ?i ?p)
    :outputs (?q) :certified (and (Conf ?q) (Kin ?i ?p ?q) (InWorkspace ?q)))
  (:rule :inputs (?q) :domain (InWorkspace ?q) :certified (Reachable ?q))
  (:function (DISTANCE ?q1 ?q2) (and (Conf ?q1) (Conf ?q2)))
  (:function (Calibration ?q) (Conf ?q)))
"""


def reach_problem(folder: Path) -> tuple[PDDLProblem, list[dict[str, Any]]]:
    """Pick both items. ``InWorkspace``/``Reachable`` appear only in the stream file; the
    ``:function Calibration`` is not in the domain (ignored, and it has no binding);
    ``Zone`` appears only in ``init``."""
    items = [{"name": "cup", "pose": np.array([2.0, 0.0])},
             {"name": "box", "pose": np.array([-1.0, 3.0])}]

    def inverse_kinematics(item: dict[str, Any], pose: np.ndarray) -> tuple[np.ndarray]:
        return (pose + np.array([0.0, 1.0]),)

    home = np.zeros(2)
    init: list[tuple[Any, ...]] = [("Conf", home), ("AtConf", home), ("HandEmpty",),
                                   ("Zone", "left")]
    for item in items:
        init += [("Item", item), ("Pose", item, item["pose"]), ("AtPose", item, item["pose"])]
    stream_map = {
        "inverse-KINEMATICS": from_fn(inverse_kinematics),
        "Distance": lambda q1, q2: float(np.linalg.norm(q1 - q2)),
    }
    goal = And(("Holding", items[0]), ("Holding", items[1]))
    problem = PDDLProblem(write(folder, "domain.pddl", REACH_DOMAIN), {},
                          write(folder, "stream.pddl", REACH_STREAMS), stream_map, init, goal)
    return problem, items


# PDDLStream's exogenous case: a stream's :domain has a fact that an action makes true.
LOOKOUT_DOMAIN = """
(define (domain lookout)
  (:predicates (Spot ?s) (Visible ?s) (At ?s) (View ?s ?v) (Photo ?v) (Conf ?s))
  (:action walk :parameters (?a ?b) :precondition (and (Conf ?a) (Conf ?b) (At ?a))
    :effect (and (At ?b) (not (At ?a))))
  (:action clear-fog :parameters (?s) :precondition (and (Spot ?s) (At ?s))
    :effect (Visible ?s))
  (:action shoot :parameters (?s ?v) :precondition (and (View ?s ?v) (At ?s))
    :effect (Photo ?v)))
"""

LOOKOUT_STREAMS = """
(define (stream lookout)
  (:stream sample-view
    :inputs (?s) :domain (and (Spot ?s) (Visible ?s))
    :outputs (?v) :certified (View ?s ?v)))
"""


def lookout_problem(folder: Path) -> PDDLProblem:
    """A photo from the spot needs ``(Visible spot)``, which only ``clear-fog`` makes true,
    after walking there: the stream's :domain mentions a fact that actions change."""
    start, spot = (0, 0), (3, 4)

    def sample_view(s: tuple[int, int]) -> Any:
        for angle in np.linspace(0.0, np.pi, 3):
            yield (np.array([s[0], s[1], angle]),)

    init = [("Conf", start), ("Conf", spot), ("At", start), ("Spot", spot)]
    goal = Exists(["?v"], ("Photo", "?v"))
    return PDDLProblem(write(folder, "domain.pddl", LOOKOUT_DOMAIN), {},
                       write(folder, "stream.pddl", LOOKOUT_STREAMS),
                       {"sample-view": from_gen_fn(sample_view)}, init, goal)


# :fluents: the stream sees the state it will be used in.
SHELF_DOMAIN = """
(define (domain shelf)
  (:predicates (Block ?b) (OnShelf ?b) (Path ?b ?t) (Taken ?b))
  (:action clear :parameters (?b) :precondition (and (Block ?b) (OnShelf ?b))
    :effect (not (OnShelf ?b)))
  (:action take :parameters (?b ?t) :precondition (and (Path ?b ?t) (OnShelf ?b))
    :effect (and (Taken ?b) (not (OnShelf ?b)))))
"""

SHELF_STREAMS = """
(define (stream shelf)
  (:stream plan-path
    :inputs (?b) :domain (Block ?b)
    :fluents (OnShelf)
    :outputs (?t) :certified (Path ?b ?t)))
"""


def shelf_problem(folder: Path) -> PDDLProblem:
    """``a`` can be taken only once ``b`` is off the shelf: the path stream fails while the
    state it is given still has ``(OnShelf b)``."""
    def plan_path(block: str, fluents: list[tuple[Any, ...]] = ()) -> Any:  # type: ignore[assignment]
        blocking = {fact[1] for fact in fluents if fact[0] == "onshelf"} - {block}
        if block == "a" and "b" in blocking:
            return None
        return (("path", block, tuple(sorted(blocking))),)

    init = [("Block", "a"), ("Block", "b"), ("OnShelf", "a"), ("OnShelf", "b")]
    return PDDLProblem(write(folder, "domain.pddl", SHELF_DOMAIN), {},
                       write(folder, "stream.pddl", SHELF_STREAMS),
                       {"plan-path": from_fn(plan_path)}, init, ("Taken", "a"))


# Wild streams: a call certifies facts it does not declare.
MAP_DOMAIN = """
(define (domain map)
  (:predicates (Room ?r) (In ?r) (Door ?a ?b) (Scanned ?r))
  (:action go :parameters (?a ?b) :precondition (and (Door ?a ?b) (In ?a))
    :effect (and (In ?b) (not (In ?a)))))
"""

MAP_STREAMS = """
(define (stream map)
  (:stream scan :inputs (?r) :domain (Room ?r)))
"""


def map_problem(folder: Path, eager: bool = True) -> tuple[PDDLProblem, dict[str, Any]]:
    """Doors are discovered by scanning rooms (a stream without outputs or :certified facts
    whose calls yield wild facts); the goal room is two doors away."""
    doors = {"hall": ["kitchen"], "kitchen": ["garden"], "garden": []}

    def scan(room: str) -> Any:
        facts = [("Door", room, other) for other in doors[room]]
        facts += [("Room", other) for other in doors[room]]
        return iter([WildOutput(values=[()], facts=facts)])

    init = [("Room", "hall"), ("In", "hall")]
    info = {"scan": StreamInfo(eager=eager)}
    return PDDLProblem(write(folder, "domain.pddl", MAP_DOMAIN), {},
                       write(folder, "stream.pddl", MAP_STREAMS), {"scan": scan}, init,
                       ("In", "garden")), info


# Cuts: a generator's outputs come with extra certified facts (WildOutput in a generator).
CUT_DOMAIN = """
(define (domain cut)
  (:predicates (Board ?b) (Piece ?b ?p) (Have ?p) (Length ?p ?l) (Fits ?p))
  (:action saw :parameters (?b ?p) :precondition (and (Piece ?b ?p) (Board ?b))
    :effect (Have ?p))
  (:action mount :parameters (?p) :precondition (and (Have ?p) (Fits ?p))
    :effect (Mounted ?p)))
"""

CUT_STREAMS = """
(define (stream cut)
  (:stream cut-piece :inputs (?b) :domain (Board ?b) :outputs (?p) :certified (Piece ?b ?p)))
"""


def cut_problem(folder: Path) -> PDDLProblem:
    """Pieces of lengths 1..4 are cut from a board; each piece's ``Fits`` fact comes only as
    a wild fact (length 3 fits). The goal needs a mounted piece."""
    def cut_piece(board: str) -> Any:
        for length in (1, 2, 3, 4):
            piece = (board, length)
            facts = [("Length", piece, length)] + ([("Fits", piece)] if length == 3 else [])
            yield WildOutput(values=[(piece,)], facts=facts)

    init = [("Board", "oak")]
    domain = CUT_DOMAIN.replace("(Fits ?p))", "(Fits ?p) (Mounted ?p))", 1)
    return PDDLProblem(write(folder, "domain.pddl", domain), {},
                       write(folder, "stream.pddl", CUT_STREAMS),
                       {"cut-piece": cut_piece}, init, Exists(["?p"], ("Mounted", "?p")))


# Domain constructs: constants, forall, exists, imply, or, conditional effects, derived
# predicates and action costs.
LAMPS_DOMAIN = """
(define (domain lamps)
  (:requirements :adl :derived-predicates :action-costs)
  (:constants main-switch)
  (:predicates (Lamp ?l) (On ?l) (Broken ?l) (Switch ?s) (Pressed ?s) (Wired ?l ?s)
               (Lit) (Dark) (Spare ?l) (Fixed ?l) (Bright ?l))
  (:functions (total-cost) (Power ?l))
  (:derived (Lit) (exists (?l) (and (Lamp ?l) (On ?l))))
  (:derived (Dark) (forall (?l) (imply (Lamp ?l) (not (On ?l)))))
  (:action repair :parameters (?l ?s)
    :precondition (and (Broken ?l) (or (Spare ?s) (Pressed main-switch)))
    :effect (and (not (Broken ?l)) (Fixed ?l) (increase (total-cost) 5)))
  (:action press :parameters (?s)
    :precondition (and (Switch ?s) (not (Pressed ?s)))
    :effect (and (Pressed ?s)
                 (forall (?l) (when (and (Wired ?l ?s) (not (Broken ?l))) (On ?l)))
                 (increase (total-cost) 1)))
  (:action boost :parameters (?l)
    :precondition (and (On ?l) (Ready ?l))
    :effect (and (Bright ?l) (increase (total-cost) (Power ?l)))))
"""

LAMPS_STREAMS = """
(define (stream lamps)
  (:stream check-ready :inputs (?l) :domain (Lamp ?l) :certified (Ready ?l))
  (:function (Power ?l) (Lamp ?l)))
"""


def lamps_problem(folder: Path) -> PDDLProblem:
    """Press the main switch (a constant) to light the lamps wired to it; the broken one must
    be repaired first (allowed once a switch is pressed: ``or``); the goal mixes a derived
    predicate, ``forall``/``imply`` and a streamed test."""
    constant_map = {"main-switch": "MAIN"}
    init = [("Switch", "MAIN"), ("Switch", "aux"), ("Spare", "kit"),
            ("Lamp", "l1"), ("Lamp", "l2"), ("Broken", "l2"),
            ("Wired", "l1", "MAIN"), ("Wired", "l2", "aux")]
    goal = And(("Lit",), ("Bright", "l1"),
               ForAll(["?l"], Imply(("Lamp", "?l"), Not(("Broken", "?l")))),
               Or(("Pressed", "aux"), ("Fixed", "l1")))
    return PDDLProblem(write(folder, "domain.pddl", LAMPS_DOMAIN), constant_map,
                       write(folder, "stream.pddl", LAMPS_STREAMS),
                       {"check-ready": from_test(lambda lamp: lamp == "l1"),
                        "power": lambda lamp: 2.5}, init, goal)


def sampler_problem(folder: Path) -> PDDLProblem:
    """``from_sampler``, ``from_list_fn`` and ``from_test`` streams: sample grasps, list
    placements, keep the far one."""
    domain = """
    (define (domain place)
      (:predicates (Obj ?o) (Grasp ?o ?g) (Placement ?o ?p) (Placed ?o ?p) (Held ?o ?g))
      (:action grab :parameters (?o ?g) :precondition (Grasp ?o ?g) :effect (Held ?o ?g))
      (:action put :parameters (?o ?g ?p) :precondition (and (Held ?o ?g) (Placement ?o ?p))
        :effect (Placed ?o ?p)))
    """
    streams = """
    (define (stream place)
      (:stream sample-grasp :inputs (?o) :domain (Obj ?o) :outputs (?g)
        :certified (Grasp ?o ?g))
      (:stream list-placements :inputs (?o) :domain (Obj ?o) :outputs (?p)
        :certified (Placement ?o ?p))
      (:stream test-far :inputs (?o ?p) :domain (Placement ?o ?p) :certified (Far ?p)))
    """
    rng = np.random.default_rng(0)
    stream_map = {
        "sample-grasp": from_sampler(lambda o: (rng.uniform(-1, 1, size=2),)),
        "list-placements": from_list_fn(lambda o: [(10.0,), (20.0,)]),
        "test-far": from_test(lambda o, p: p > 15.0),
    }
    return PDDLProblem(write(folder, "domain.pddl", domain), {},
                       write(folder, "stream.pddl", streams), stream_map, [("Obj", "mug")],
                       Exists(["?p"], And(("Placed", "mug", "?p"), ("Far", "?p"))))


# A roadmap whose edges only a wild stream certifies, for configurations another stream
# samples: no optimistic plan exists, so only calling the streams finds the plan.
ROADMAP_DOMAIN = """
(define (domain roadmap)
  (:predicates (Conf ?q) (At ?q) (Edge ?a ?b) (Dock ?q))
  (:action drive :parameters (?a ?b) :precondition (and (Edge ?a ?b) (At ?a))
    :effect (and (At ?b) (not (At ?a)))))
"""

ROADMAP_STREAMS = """
(define (stream roadmap)
  (:stream sample-dock :outputs (?q) :certified (and (Conf ?q) (Dock ?q)))
  (:stream connect :inputs (?q) :domain (Conf ?q)))
"""


def roadmap_problem(folder: Path) -> PDDLProblem:
    """``connect`` links each new configuration to those seen before (wild ``Edge`` facts)."""
    seen: list[float] = []

    def connect(q: float) -> Any:
        facts = [fact for other in seen for fact in (("Edge", other, q), ("Edge", q, other))]
        seen.append(q)
        return iter([WildOutput(facts=facts)])

    docks = iter([2.5, 7.5])
    return PDDLProblem(write(folder, "domain.pddl", ROADMAP_DOMAIN), {},
                       write(folder, "stream.pddl", ROADMAP_STREAMS),
                       {"sample-dock": from_fn(lambda: (next(docks),)), "connect": connect},
                       [("Conf", 0.0), ("At", 0.0)],
                       Exists(["?q"], And(("At", "?q"), ("Dock", "?q"))))
