"""Small scripts written in PDDLStream's style (for these tests; not PDDLStream's files),
run through ltamp's ``pddlstream`` alias: a courier carries a parcel along a line."""

from __future__ import annotations

import textwrap
from pathlib import Path

DOMAIN = """
(define (domain courier)
  (:requirements :strips :action-costs)
  (:predicates (Parcel ?p) (Spot ?x) (At ?x) (ParcelAt ?p ?x) (Carrying ?p) (Route ?x ?y)
               (DropSpot ?p ?x) (Delivered ?p))
  (:functions (Length ?x ?y))
  (:action drive :parameters (?x ?y) :precondition (and (Route ?x ?y) (At ?x))
    :effect (and (At ?y) (not (At ?x)) (increase (total-cost) (Length ?x ?y))))
  (:action load :parameters (?p ?x) :precondition (and (ParcelAt ?p ?x) (At ?x))
    :effect (and (Carrying ?p) (not (ParcelAt ?p ?x)) (increase (total-cost) 1)))
  (:action unload :parameters (?p ?x)
    :precondition (and (Carrying ?p) (At ?x) (DropSpot ?p ?x))
    :effect (and (Delivered ?p) (not (Carrying ?p)) (increase (total-cost) 1))))
"""
STREAM = """
(define (stream courier)
  (:stream sample-drop :inputs (?p) :domain (Parcel ?p) :outputs (?x)
    :certified (and (Spot ?x) (DropSpot ?p ?x)))
  (:stream test-route :inputs (?x ?y) :domain (and (Spot ?x) (Spot ?y))
    :certified (Route ?x ?y))
  (:function (Length ?x ?y) (and (Spot ?x) (Spot ?y))))
"""
PRIMITIVES = """
import numpy as np

MAX_HOP = 5.0


def drop_spots(parcel):
    # The first candidate is out of reach of the pickup spot (3): the planner must ask for
    # the next one.
    for x in (12.0, 7.0):
        yield (np.array([x]),)


def route_ok(x, y):
    return 0 < abs(float(x[0] - y[0])) <= MAX_HOP


def route_length(x, y):
    return abs(float(x[0] - y[0]))
"""
RUN = """
#!/usr/bin/env python
from __future__ import print_function

import sys

import numpy as np

from pddlstream.algorithms.meta import solve, create_parser
from pddlstream.language.constants import PDDLProblem, print_solution
from pddlstream.language.generator import from_gen_fn, from_test
from pddlstream.language.stream import StreamInfo
from pddlstream.utils import read, get_file_path, INF, Profiler
from primitives import drop_spots, route_ok, route_length


def get_problem():
    home, pickup = np.array([0.0]), np.array([3.0])
    stream_map = {
        'sample-drop': from_gen_fn(drop_spots),
        'test-route': from_test(route_ok),
        'Length': route_length,
    }
    init = [('Spot', home), ('At', home), ('Spot', pickup), ('Parcel', 'box'),
            ('ParcelAt', 'box', pickup)]
    return PDDLProblem(read(get_file_path(__file__, 'domain.pddl')), {},
                       read(get_file_path(__file__, 'stream.pddl')), stream_map, init,
                       ('Delivered', 'box'))


def main():
    parser = create_parser()
    parser.add_argument('--exit', type=int, default=0, help='exit code after solving')
    parser.add_argument('--fail', action='store_true', help="raise the script's own error")
    args = parser.parse_args()
    print('Algorithm:', args.algorithm)
    with Profiler(num=None):
        solution = solve(get_problem(), algorithm=args.algorithm, unit_costs=args.unit,
                         max_time=30, success_cost=INF, planner='ff-astar', verbose=False,
                         stream_info={'test-route': StreamInfo(p_success=0.5)})
    print_solution(solution)
    plan, cost, certificate = solution
    if plan is None:
        sys.exit(3)
    print('Drop at:', float(plan[-1].args[1][0]))
    if args.fail:
        raise ValueError("the script's own bug")
    sys.exit(args.exit)


if __name__ == '__main__':
    main()
"""
CONSTRAINED = """
from pddlstream.algorithms.constraints import PlanConstraints, WILD
from pddlstream.algorithms.meta import analyze_goal, solve
from pddlstream.language.constants import print_solution
from run import get_problem

problem = get_problem()
print('Facts:', sorted(fact[0] for fact in analyze_goal(problem, use_actions=True)))
skeleton = [('load', ['box', WILD]), ('drive', [WILD, '?x']), ('unload', ['box', '?x'])]
solution = solve(problem, constraints=PlanConstraints(skeletons=[skeleton], exact=False),
                 max_time=30, verbose=False)
print_solution(solution)
"""
MISSING = """
from pddlstream.algorithms.meta import solve
from pddlstream.algorithms.skeleton import SkeletonQueue

queue = SkeletonQueue(None, domain=None)
"""
UNKNOWN = """
from pddlstream.algorithms.meta import solve
from pddlstream.algorithms.downward import get_problem_internals
"""
BROKEN = """
from pddlstream.algorithms.meta import solve
from pddlstream.language.constants import PDDLProblem
from pddlstream.utils import read, get_file_path

solve(PDDLProblem(read(get_file_path(__file__, 'broken.pddl')), {}, None, {}, [], ('Done',)))
"""
BROKEN_DOMAIN = """(define (domain broken)
  (:predicates (Done))
  (:action finish :parameters () :effect (Done))
"""


def write_courier(folder: Path, package: str | None = None) -> Path:
    """The courier script and its files in ``folder`` (in the package ``package`` if given,
    importing ``package.primitives`` as scripts run with ``python -m`` do); its path."""
    where = folder / package if package else folder
    where.mkdir(parents=True, exist_ok=True)
    run = RUN if package is None else RUN.replace("from primitives", f"from {package}.primitives")
    files = {"domain.pddl": DOMAIN, "stream.pddl": STREAM, "primitives.py": PRIMITIVES,
             "run.py": run, "constrained.py": CONSTRAINED, "missing.py": MISSING,
             "unknown.py": UNKNOWN, "broken.py": BROKEN, "broken.pddl": BROKEN_DOMAIN}
    if package:
        files["__init__.py"] = ""
    for name, text in files.items():
        (where / name).write_text(textwrap.dedent(text).lstrip())
    return where / "run.py"
