"""A PDDLStream-style task-and-motion planner.

* :mod:`.pddl` — syntax (frozen dataclasses) and parsers for PDDL domains/problems and
  PDDLStream stream files; semantic checks are separate from parsing.
* :mod:`.search` — grounding by relaxed reachability and heuristic search (FF, lazy greedy
  best-first with preferred operators, weighted A*), with derived predicates, conditional
  effects, negative preconditions and action costs, all in-process.
* :mod:`.streams` — binding stream declarations to Python samplers, tests and functions.
* :mod:`.algorithms` — the incremental and focused PDDLStream algorithms.
* :mod:`.problem` — loading YAML problem files; :mod:`.validate` — an independent plan checker.
"""
