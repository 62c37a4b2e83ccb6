"""In-process grounding and heuristic search for PDDL with derived predicates."""
