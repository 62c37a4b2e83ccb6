"""PDDLStream algorithms over a :class:`~ltamp_cli.planner.problem.PlanningProblem`."""
