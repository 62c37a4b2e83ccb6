"""A small script in PDDLStream's style written for NumPy 1 (for these tests; not
PDDLStream's files): a crate is stored in a shelf slot; the samplers and tests use names
NumPy 2 removed (``from numpy import mat, float_``, ``np.product``, ``np.NaN``, ``np.in1d``,
``np.trapz``, ``np.alltrue``, and ``from numpy import *`` in the module it imports)."""

from __future__ import annotations

import textwrap
from pathlib import Path

DOMAIN = """
(define (domain shelf)
  (:requirements :strips)
  (:predicates (Crate ?c) (Slot ?s) (Fits ?c ?s) (Stored ?c ?s) (Done ?c))
  (:action store :parameters (?c ?s) :precondition (and (Crate ?c) (Slot ?s) (Fits ?c ?s))
    :effect (and (Stored ?c ?s) (Done ?c))))
"""
STREAM = """
(define (stream shelf)
  (:stream sample-slot :inputs (?c) :domain (Crate ?c) :outputs (?s) :certified (Slot ?s))
  (:stream test-fits :inputs (?c ?s) :domain (and (Crate ?c) (Slot ?s))
    :certified (Fits ?c ?s)))
"""
# A module the script imports, star-importing numpy as NumPy-1 code often does.
GEOMETRY = """
from numpy import *


def volume(extent):
    if product(extent) != cumproduct(extent)[-1]:
        raise AssertionError('product and cumproduct disagree')
    return float(product(extent))


UNKNOWN = NaN
"""
RUN = """
#!/usr/bin/env python
from __future__ import print_function

import sys

import numpy as np
from numpy import mat, float_

from pddlstream.algorithms.meta import solve, create_parser
from pddlstream.language.constants import PDDLProblem, print_solution
from pddlstream.language.generator import from_gen_fn, from_test
from pddlstream.utils import read, get_file_path

from geometry import volume, UNKNOWN

CRATE = np.array([2.0, 1.0, 3.0])  # extent (m)


def rotated(extent):
    # A quarter turn about z swaps the first two extents (NumPy 1 matrix algebra).
    turn = mat([[0, 1, 0], [1, 0, 0], [0, 0, 1]])
    return np.asarray(turn * mat(extent).T).ravel()


def sample_slot(crate):
    # The first slot is too small for the crate in any orientation; the second fits it
    # once turned.
    for extent in ([1.0, 1.0, 1.0], [1.5, 2.5, 3.0]):
        yield (np.array(extent, dtype=float_),)


def test_fits(crate, slot):
    if not np.isnan(UNKNOWN):
        raise AssertionError('NaN is not nan')
    turned = rotated(CRATE)
    inside = np.alltrue(turned <= slot) and not np.sometrue(turned > slot)
    return bool(np.in1d([inside], [True])[0]) and volume(CRATE) <= volume(slot)


def main():
    parser = create_parser()
    parser.add_argument('--asfarray', action='store_true',
                        help='also use a removed name without an exact equivalent')
    args = parser.parse_args()
    if args.asfarray:
        np.asfarray([1, 2])
    problem = PDDLProblem(read(get_file_path(__file__, 'domain.pddl')), {},
                          read(get_file_path(__file__, 'stream.pddl')),
                          {'sample-slot': from_gen_fn(sample_slot),
                           'test-fits': from_test(test_fits)},
                          [('Crate', 'crate')], ('Done', 'crate'))
    solution = solve(problem, algorithm=args.algorithm, max_time=30, verbose=False)
    print_solution(solution)
    if solution.plan is None:
        sys.exit(3)
    slot = solution.plan[0].args[1]
    print('Slot:', [float(x) for x in slot], 'volume:', volume(slot),
          'dtype:', slot.dtype.name, 'area:', float(np.trapz([0.0, 2.0], dx=3.0)),
          'mat:', type(np.mat([1])).__name__)


if __name__ == '__main__':
    main()
"""


def write_shelf(folder: Path) -> Path:
    """The NumPy-1 shelf script and its files in ``folder``; the script's path."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in {"domain.pddl": DOMAIN, "stream.pddl": STREAM, "geometry.py": GEOMETRY,
                       "run.py": RUN}.items():
        (folder / name).write_text(textwrap.dedent(text).lstrip())
    return folder / "run.py"
