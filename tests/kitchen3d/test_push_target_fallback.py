"""push_to_reach: a target the bowl can only be pushed to with the fingers *along* the line
(one contact, which drifts: 0.015-0.069 m) is given up for another target, not pushed to
(issue #20).

``(-0.1, 0.2)`` in the middle region is the one target of ``push_to_reach_reach_map.json``
whose across push (open fingers, two contacts) arm r1 does not reach while the along push
is found. The push stream yields no push there (a round object only across), so the planner
must take another placement. The test makes the bowl's first sampled placement that target.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.backends.pybullet.tamp import skill_paths
from ltamp_cli.backends.pybullet.tamp.planning import PlanningWorld
from ltamp_cli.backends.pybullet.tamp.scene import scene_from_world
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem

ROOT = Path(__file__).resolve().parents[2]
PROBLEM = ROOT / "problems/kitchen3d/push_to_reach.yaml"
BOWL_AT = (0.45, 0.3)
ALONG_ONLY = (-0.1, 0.2)


def test_an_along_only_target_is_not_pushed_to() -> None:
    problem = load_problem(PROBLEM)
    world = copy.deepcopy(dict(problem.world))
    # The target is along-only: the stream finds no (across) push of the bowl there, ...
    streams = problem.streams_factory(world, np.random.default_rng(0))
    assert not [out for out in streams["sample-push"].function(1, "bowl", BOWL_AT, ALONG_ONLY)
                if out]
    # ... while the hand along the line (closed) has a path to it.
    planning = PlanningWorld(scene_from_world(world))
    try:
        bowl = planning.spec.objects["bowl"]
        along = math.atan2(ALONG_ONLY[1] - BOWL_AT[1], ALONG_ONLY[0] - BOWL_AT[0]) + math.pi / 2
        assert not skill_paths.push_holds_line(bowl, BOWL_AT, ALONG_ONLY, along)
        poses = skill_paths.push_hand_poses(bowl, BOWL_AT, ALONG_ONLY, planning.table_z, along)
        path = planning.follow_hand_path(poses, 1, np.random.default_rng(0), "push",
                                         touching="bowl", finger_gap=0.0)
        assert path is not None
    finally:
        planning.close()

    # The bowl's first sampled placement is that target: the plan pushes elsewhere, open.
    original = problem.streams_factory
    assert original is not None

    def pinned_factory(*args: Any, **kwargs: Any) -> dict[str, Any]:
        made = dict(original(*args, **kwargs))
        entry = made["sample-placement"]
        sample = entry.function

        def pinned(name: str, region: str) -> Iterator[tuple[tuple[float, float]]]:
            if name == "bowl":
                yield (ALONG_ONLY,)
            yield from sample(name, region)

        made["sample-placement"] = dataclasses.replace(entry, function=pinned)
        return made

    pinned_problem = dataclasses.replace(problem, streams_factory=pinned_factory)
    result = solve(pinned_problem, PlannerConfig(**{**problem.planner_options, "seed": 0,
                                                     "max_time": 600.0}))
    assert result.solved
    pushes = [step for step in result.plan or () if step.name == "push"]
    for step in pushes:
        target, arm_path = step.values[2], step.values[5]
        assert tuple(np.round(target, 4)) != ALONG_ONLY
        assert arm_path.finger_gap == skill_paths.PUSH_FINGER_GAP_M
