"""Infeasible problems with endless generators, and solvable look-alikes (issue #19, D).

Each corpus problem pairs an infeasibility that rests on deletes or negation (a consumed
resource, a negated precondition that never becomes false, facts deleted by the only way
to reach another) with a look-alike that one more action or one movable object makes
solvable. Every generator is endless, so no algorithm can prove infeasibility by running
out of samples. ``expected``: ``infeasible`` (provable in the abstract task of
:mod:`ltamp_cli.planner.algorithms.abstract_task` or the relaxation), ``solved``, or
``unprovable`` (infeasible, but only through facts about values not sampled yet: every
placement collides; more distinct outputs than tokens; the answer is a timeout).

Runs every problem with every algorithm and prints, per run, status, CPU seconds (this
process, ``time.process_time``), what decided (``infeasibility_check``, ``completed_by``)
and whether the answer is wrong (``infeasible`` for a solvable problem, ``solved`` for an
infeasible one, or an invalid plan). Writes JSON; ``--compare BEFORE AFTER`` prints the
paired table of two such files.

    OMP_NUM_THREADS=1 PYTHONPATH=. .venv/bin/python bench/infeasible_corpus.py
        [--max-time 3] [--algorithms adaptive,binding] [--problems a,b] [--out F.json]
    .venv/bin/python bench/infeasible_corpus.py --compare BEFORE.json AFTER.json
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
import tempfile
import textwrap
import time
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
ALGORITHMS = ("adaptive", "binding", "focused", "incremental")
WRONG = {"solved": "infeasible", "infeasible": "solved", "unprovable": "solved"}


@dataclass(frozen=True)
class CorpusProblem:
    """One problem: PDDL texts, bindings and the YAML problem (``{domain}`` and
    ``{bindings}`` are filled with paths), and the expected answer."""

    name: str
    expected: str  # "infeasible", "solved" or "unprovable"
    why: str
    problem: str
    domain: str = ""
    streams: str = ""
    bindings: str = ""
    shared_domain: str = ""  # a domain folder of the repository instead of the texts


# --- visits: go(?q) moves through stages s0 -> s1 -> ...; sample(r) yields 1.0, 2.0, ...
VISITS_STREAMS = """
(define (stream visits)
  (:stream sample :inputs (?r) :domain (Region ?r) :outputs (?q) :certified (Conf ?q)))
"""
VISITS_BINDINGS = """
import itertools

def make_streams(world, rng):
    def sample(r):
        for i in itertools.count(1):
            yield (float(i),)
    return {"sample": sample}
"""


def visits_domain(precondition: str = "", effect: str = "", more: str = "",
                  predicates: str = "") -> str:
    return f"""
(define (domain visits)
  (:requirements :strips :negative-preconditions :equality :derived-predicates
                 :conditional-effects)
  (:predicates (Conf ?q) (Seen ?q) (Stage ?s) (Next ?s ?t) (Region ?r) {predicates})
  (:action go
    :parameters (?q ?s ?t)
    :precondition (and (Conf ?q) (Stage ?s) (Next ?s ?t) {precondition})
    :effect (and (Seen ?q) (Stage ?t) (not (Stage ?s)) {effect}))
  {more})
"""


def visits_problem(stages: int, goal: str = "", init: tuple[str, ...] = (),
                   objects: tuple[str, ...] = ()) -> str:
    names = [f"s{i}" for i in range(stages + 1)]
    facts = ["(Region r)", f"(Stage {names[0]})",
             *(f"(Next {a} {b})" for a, b in itertools.pairwise(names)), *init]
    listed = ", ".join(f"{n}: null" for n in ["r", *names, *objects])
    quoted = ", ".join(f'"{fact}"' for fact in facts)
    return (f"domain: {{domain}}\nbindings: {{bindings}}\nworld: {{{{}}}}\n"
            f"objects: {{{{{listed}}}}}\ninit: [{quoted}]\n"
            f"goal: {goal or f'(Stage {names[-1]})'}\n")


def _visits(name: str, expected: str, why: str, stages: int, goal: str = "",
            init: tuple[str, ...] = (), objects: tuple[str, ...] = (),
            streams: str = VISITS_STREAMS, **domain: str) -> CorpusProblem:
    return CorpusProblem(name, expected, why, visits_problem(stages, goal, init, objects),
                         visits_domain(**domain), streams, VISITS_BINDINGS)


TOKEN = {"precondition": "(Token)", "effect": "(not (Token))", "predicates": "(Token)"}
RECHARGE = "(:action recharge :parameters () :precondition (Charger) :effect (Token))"
UNLOCK = "(:action unlock :parameters () :precondition (Key) :effect (not (Locked)))"
BLOCKED_STREAMS = """
(define (stream visits)
  (:stream sample :inputs (?r) :domain (Region ?r) :outputs (?q)
    :certified (and (Conf ?q) (Blocked ?q))))
"""
LOOK_DOMAIN = """
(define (domain looks)
  (:predicates (Conf ?q) (Seen ?q) (Token ?t) (Region ?r))
  (:action look :parameters (?q ?t) :precondition (and (Conf ?q) (Token ?t))
    :effect (and (Seen ?q) (not (Token ?t)))))
"""
THREE_DISTINCT = ("(exists (?a ?b ?c) (and (Seen ?a) (Seen ?b) (Seen ?c) (not (= ?a ?b)) "
                  "(not (= ?a ?c)) (not (= ?b ?c))))")


def _looks(name: str, expected: str, why: str, tokens: int) -> CorpusProblem:
    objects = ", ".join(["r: null", *(f"t{i}: null" for i in range(tokens))])
    init = ", ".join(['"(Region r)"', *(f'"(Token t{i})"' for i in range(tokens))])
    problem = (f"domain: {{domain}}\nbindings: {{bindings}}\nworld: {{{{}}}}\n"
               f"objects: {{{{{objects}}}}}\ninit: [{init}]\ngoal: {THREE_DISTINCT}\n")
    return CorpusProblem(name, expected, why, problem, LOOK_DOMAIN, VISITS_STREAMS,
                         VISITS_BINDINGS)


# --- tamp2d_uniform (PDDLStream continuous_tamp style): uniform placements, collisions only
# through the negated derived UnsafePose over test-cfree.
def tamp2d(goal: str, movable_b: bool = True, pg: float | None = None,
           regions: str = "{table: [-11.0, 10.0], goal: [5.0, 10.0]}") -> str:
    extra_objects = f"\n  pg: {pg}" if pg is not None else ""
    extra_init = "\n  - (Pose a pg)\n  - (Contained a pg goal)" if pg is not None else ""
    block_b = "\n  - (Block b)" if movable_b else ""
    regions = regions.replace("{", "{{").replace("}", "}}")  # kept by str.format
    return f"""domain: {{domain}}
bindings: {{bindings}}
world:
  regions: {regions}
objects:
  a: null
  b: null
  table: null
  goal: null
  pa: 0.0
  pb: 7.5
  q0: [-5.0, 6.0]{extra_objects}
init:
  - (Block a){block_b}
  - (Region table)
  - (Region goal)
  - (Pose a pa)
  - (Pose b pb)
  - (AtPose a pa)
  - (AtPose b pb)
  - (Contained a pa table)
  - (Contained b pb table)
  - (Contained b pb goal){extra_init}
  - (Conf q0)
  - (AtConf q0)
  - (HandEmpty)
  - (CanMove)
goal: {goal}
"""


CORPUS: tuple[CorpusProblem, ...] = (
    _visits("visits_stages_both", "infeasible",
            "the goal needs s0 and s2 at once; go deletes the stage it leaves", 2,
            goal="(and (Stage s2) (Stage s0))"),
    _visits("visits_token", "infeasible", "two visits, one token that go consumes", 2,
            init=("(Token)",), **TOKEN),
    _visits("visits_token_recharge", "solved", "as visits_token, with a charger", 2,
            init=("(Token)", "(Charger)"), more=RECHARGE,
            predicates="(Token) (Charger)", precondition="(Token)",
            effect="(not (Token))"),
    _visits("visits_locked", "infeasible",
            "go needs (not (Locked)); Locked holds and nothing deletes it", 2,
            init=("(Locked)",), precondition="(not (Locked))",
            predicates="(Locked) (Key)", more=UNLOCK),
    _visits("visits_locked_key", "solved", "as visits_locked, with the key", 2,
            init=("(Locked)", "(Key)"), precondition="(not (Locked))",
            predicates="(Locked) (Key)", more=UNLOCK),
    _visits("visits_two_outputs", "solved",
            "red team round 7: two distinct configurations of one instance", 2,
            precondition="(not (Seen ?q))"),
    _visits("visits_four_outputs", "solved",
            "as visits_two_outputs with four visits (more than the values sampled before "
            "the check)", 4, precondition="(not (Seen ?q))"),
    _visits("visits_when_fresh", "solved",
            "go needs (Fresh), which a revisit deletes (a conditional effect): five "
            "distinct configurations keep it", 5,
            init=("(Fresh)",), precondition="(Fresh)", predicates="(Fresh)",
            effect="(when (Seen ?q) (not (Fresh)))"),
    _visits("visits_busy_derived", "solved",
            "go needs (not (Busy)), Busy while a visit is pending (derived); finish ends "
            "it; each configuration once", 3,
            precondition="(not (Busy)) (not (Seen ?q))",
            effect="(Pending ?q)", predicates="(Pending ?q) (Busy)",
            more="(:derived (Busy) (exists (?x) (Pending ?x)))\n"
                 "  (:action finish :parameters (?q) :precondition (Pending ?q)\n"
                 "    :effect (not (Pending ?q)))"),
    _visits("visits_unreachable", "infeasible",
            "(Seen r): r is no configuration (the relaxation proves it)", 2,
            goal="(and (Stage s2) (Seen r))"),
    _visits("visits_blocked_samples", "unprovable",
            "every sample is certified Blocked and go needs (not (Blocked ?q))", 2,
            streams=BLOCKED_STREAMS, precondition="(not (Blocked ?q))",
            predicates="(Blocked ?q)"),
    _looks("looks_three_two_tokens", "unprovable",
           "three distinct configurations seen, two tokens (stand-ins merge)", 2),
    _looks("looks_three_three_tokens", "solved", "three distinct seen, three tokens", 3),
    CorpusProblem("tamp2d_hold_two", "infeasible",
                  "hold a and b at once: pick consumes HandEmpty",
                  tamp2d("(and (Holding a) (Holding b))"),
                  shared_domain="tamp2d_uniform"),
    CorpusProblem("tamp2d_hold_a_move_b", "solved",
                  "hold a after moving b off its pose",
                  tamp2d("(and (Holding a) (not (AtPose b pb)))"),
                  shared_domain="tamp2d_uniform"),
    CorpusProblem("tamp2d_fixed_obstacle", "infeasible",
                  "place a at pg, which collides with b, and b cannot be grasped",
                  tamp2d("(AtPose a pg)", movable_b=False, pg=7.0),
                  shared_domain="tamp2d_uniform"),
    CorpusProblem("tamp2d_movable_obstacle", "solved",
                  "as tamp2d_fixed_obstacle, b movable",
                  tamp2d("(AtPose a pg)", pg=7.0), shared_domain="tamp2d_uniform"),
    CorpusProblem("tamp2d_goal_full", "unprovable",
                  "a in the goal region, which immovable b leaves no room in",
                  tamp2d("(In a goal)", movable_b=False), shared_domain="tamp2d_uniform"),
)
BY_NAME = {problem.name: problem for problem in CORPUS}


def write_problem(problem: CorpusProblem, folder: Path) -> Path:
    """Write ``problem`` under ``folder`` (its own sub-folder); returns the YAML path."""
    base = folder / problem.name
    base.mkdir(parents=True, exist_ok=True)
    if problem.shared_domain:
        domain = REPO / "domains" / problem.shared_domain
        bindings = domain / "streams.py"
    else:
        domain = base / "dom"
        domain.mkdir(exist_ok=True)
        (domain / "domain.pddl").write_text(textwrap.dedent(problem.domain).lstrip())
        (domain / "stream.pddl").write_text(textwrap.dedent(problem.streams).lstrip())
        bindings = base / "bindings.py"
        bindings.write_text(textwrap.dedent(problem.bindings).lstrip())
    path = base / "problem.yaml"
    path.write_text(problem.problem.format(domain=domain, bindings=bindings))
    return path


def run_one(problem: CorpusProblem, path: Path, algorithm: str, max_time: float
            ) -> dict[str, object]:
    """One solve: status, CPU and wall seconds, what decided, and whether it is wrong."""
    from ltamp_cli.planner.algorithms.common import PlannerConfig
    from ltamp_cli.planner.api import solve
    from ltamp_cli.planner.problem import load_problem
    from ltamp_cli.planner.validate import validate_plan

    loaded = load_problem(path)
    cpu, wall = time.process_time(), time.perf_counter()
    result = solve(loaded, PlannerConfig(algorithm=algorithm, max_time=max_time))
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    valid = validate_plan(loaded, result).valid if result.solved else None
    wrong = result.status == WRONG[problem.expected] or valid is False
    return {"problem": problem.name, "expected": problem.expected, "algorithm": algorithm,
            "status": result.status, "cpu_s": cpu, "wall_s": wall, "valid": valid,
            "wrong": wrong, "check": result.stats.get("infeasibility_check", ""),
            "completed_by": result.stats.get("completed_by", ""),
            "abstract_time_s": result.stats.get("abstract_time_s")}


def run(args: argparse.Namespace) -> int:
    names = [n for n in args.problems.split(",") if n] or list(BY_NAME)
    unknown = [n for n in names if n not in BY_NAME]
    if unknown:
        print(f"error: unknown problem {unknown[0]!r}", file=sys.stderr)
        return 2
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for name in names:
            path = write_problem(BY_NAME[name], Path(folder))
            for algorithm in args.algorithms.split(","):
                row = run_one(BY_NAME[name], path, algorithm, args.max_time)
                rows.append(row)
                print(f"{name:28s} {algorithm:11s} {row['expected']:10s} "
                      f"{row['status']:10s} {row['cpu_s']:7.3f} s"
                      f"{'  WRONG' if row['wrong'] else ''}  {row['check']}", flush=True)
    wrong = sum(bool(row["wrong"]) for row in rows)
    print(f"{wrong} wrong answer(s) in {len(rows)} runs (max_time {args.max_time} s)")
    if args.out:
        args.out.write_text(json.dumps({"max_time": args.max_time, "rows": rows}, indent=1))
        print(f"wrote {args.out}")
    return 0


def _flag(row: dict[str, object]) -> str:
    return f"{row['status']}{' **WRONG**' if row['wrong'] else ''}"


def compare(before_path: Path, after_path: Path) -> int:
    """Print a Markdown table pairing the runs of two result files."""
    before = {(r["problem"], r["algorithm"]): r
              for r in json.loads(before_path.read_text())["rows"]}
    after = json.loads(after_path.read_text())["rows"]
    print("| problem | expected | algorithm | before | CPU s | after | CPU s | decided by |")
    print("|---|---|---|---|---|---|---|---|")
    for row in after:
        old = before.get((row["problem"], row["algorithm"]))
        if old is None:
            continue
        how = row["check"] or ""
        if row["completed_by"]:
            how = (how + "; " if how else "") + "fallback: incremental"
        print(f"| {row['problem']} | {row['expected']} | {row['algorithm']} | {_flag(old)} | "
              f"{old['cpu_s']:.3f} | {_flag(row)} | {row['cpu_s']:.3f} | {how} |")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-time", type=float, default=3.0)
    parser.add_argument("--algorithms", default=",".join(ALGORITHMS))
    parser.add_argument("--problems", default="")
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--compare", nargs=2, type=Path, metavar=("BEFORE", "AFTER"))
    args = parser.parse_args(argv)
    if args.compare:
        return compare(*args.compare)
    from ltamp_cli.threads import use_one_thread

    use_one_thread()
    return run(args)


if __name__ == "__main__":
    sys.exit(main())
