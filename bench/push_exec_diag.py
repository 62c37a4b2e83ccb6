"""One Kitchen3D push_to_reach execution on PyBullet, with the push recorded step by step.

Plans ``problems/kitchen3d/push_to_reach.yaml`` with ``--seed`` (``--max-time`` s of wall
clock), executes the plan on PyBullet and records, after every simulated step of the push,
the hand's (grasp target's) position, the pushed object's position, yaw and tilt, and the
arm-object contacts (count, normal force, arm links). ``--fingers closed`` / ``open``
overrides the executor's finger gap for the push (``auto``: the executor's own rule,
``skill_paths.push_finger_gap``). Prints and writes (``--out``, JSON) the summary: the
planned hand path's contact line, the object's largest distance from the line, its final
error, its largest yaw, which links touched it, the goal's bead counts, CPU seconds; and
the trajectory every ``--every`` steps. ``--pour-trials N``: the plan's pour control also
runs as the pour skill's own trial with seeds 0..N-1 (does the learned pour spill in its
own simulation too?); ``--no-execute``: only that.

``--reach-map N``: no planning: arm r1's push of the bowl from where it stands to each of an
N x N grid of targets in the ``middle`` region, for each hand yaw the push stream may use
(fingers across the line, across turned by π, along it), solved from the arm's home
configuration alone (as before issue #20's fix) and by the planning world
(``PlanningWorld.follow_hand_path``: from the home posture turned to face the push, then from
home); per target and yaw: found or the follower's failure and where (densified waypoint),
the hand's end distance from the base (m), CPU seconds.

    OMP_NUM_THREADS=1 nice -n 5 .venv/bin/python bench/push_exec_diag.py --reach-map 4 \\
        --out docs/results/exec3d/push_to_reach_reach_map.json

    OMP_NUM_THREADS=1 nice -n 5 .venv/bin/python bench/push_exec_diag.py --seed 1 \\
        --out docs/results/exec3d/push_to_reach_seed1_auto.json
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pybullet as p

ROOT = Path(__file__).resolve().parents[1]
PROBLEM = ROOT / "problems" / "kitchen3d" / "push_to_reach.yaml"
GAPS = {"closed": 0.0, "open": 0.08}


def pour_trials(problem: Any, result: Any, seeds: int) -> list[dict[str, Any]]:
    """The plan's pour control run as the pour skill's own PyBullet trial (the simulation the
    model learned from: the scene's cup and bowl) with trial seeds ``0 .. seeds - 1``."""
    from ltamp_cli.backends.pybullet.backend import Kitchen3DBackend
    from ltamp_cli.backends.pybullet.tamp.scene import scene_from_world
    from ltamp_cli.backends.pybullet.tamp.skill_paths import pour_context

    spec = scene_from_world(problem.world)
    backend = Kitchen3DBackend()
    out = []
    try:
        for step in result.plan or ():
            if step.name != "pour":
                continue
            cup, bowl = (str(a).lower() for a in (step.args[0], step.args[2]))
            context = pour_context(spec.objects[cup], spec.objects[bowl])
            control = np.asarray(step.values[6], dtype=float)
            for trial_seed in range(seeds):
                c0 = time.process_time()
                trial = backend.run_trial("pour", context, control, trial_seed)
                out.append({"context": context.tolist(), "control": control.tolist(),
                            "seed": trial_seed, "score": float(trial.score),
                            "valid": bool(trial.valid), "cpu_s": time.process_time() - c0,
                            "info": {k: v for k, v in trial.info.items()
                                     if isinstance(v, (int, float, str))}})
    finally:
        backend.close()
    return out


def run(seed: int, fingers: str, max_time: float, every: int, pour_seeds: int = 0,
        execute: bool = True) -> dict[str, Any]:
    """Plan and execute; the push's record (see the module docstring)."""
    from ltamp_cli.backends.pybullet import executor as ex
    from ltamp_cli.planner.algorithms.common import PlannerConfig
    from ltamp_cli.planner.api import solve
    from ltamp_cli.planner.problem import load_problem

    problem = load_problem(PROBLEM)
    c0 = time.process_time()
    result = solve(problem, PlannerConfig(**{**problem.planner_options, "seed": seed,
                                             "max_time": max_time}))
    record: dict[str, Any] = {"seed": seed, "fingers": fingers, "status": result.status,
                              "plan_cpu_s": time.process_time() - c0,
                              "actions": [s.name for s in result.plan or ()], "steps": []}
    if not result.solved:
        return record
    if pour_seeds:
        record["pour_trials"] = pour_trials(problem, result, pour_seeds)
    if not execute:
        return record

    class Run(ex.Kitchen3DRun):
        def push_finger_gap(self, arm_index: int, name: str, goal: tuple[float, float]
                            ) -> float:
            gap = super().push_finger_gap(arm_index, name, goal)
            return gap if fingers == "auto" else GAPS[fingers]

        def push(self, name: str, goal: tuple[float, float], path: Any) -> None:
            arm = self.scene.arms[path.arm]
            here = arm.get_configuration()
            planned = []
            for q in path.configurations:
                arm.set_configuration(q)
                planned.append(arm.end_effector_pose().position.tolist())
            arm.set_configuration(here)
            record.update(planned_hand=planned, goal=list(goal),
                          start_xy=list(self.object_xy(name)))
            body = self.bodies[name].body
            client = self.world.client
            plain_step = self._step

            def step() -> None:
                plain_step()
                position, quaternion = p.getBasePositionAndOrientation(
                    body, physicsClientId=client)
                roll, pitch, yaw = p.getEulerFromQuaternion(quaternion)
                contacts = p.getContactPoints(arm.body_id, body, physicsClientId=client)
                record["steps"].append({
                    "hand": arm.end_effector_pose().position.tolist(), "obj": list(position),
                    "yaw": yaw, "tilt": [roll, pitch], "contacts": len(contacts),
                    "force_n": float(sum(c[9] for c in contacts)),
                    "links": sorted({int(c[3]) for c in contacts})})

            self._step = step  # type: ignore[method-assign]
            try:
                super().push(name, goal, path)
            finally:
                self._step = plain_step  # type: ignore[method-assign]

    executor = ex.Kitchen3DExecutor()
    executor.run_class = Run
    c0 = time.process_time()
    report = executor.execute(problem, result, seed)
    record.update(exec_cpu_s=time.process_time() - c0, executed=report.success,
                  goal_holds=report.goal_holds,
                  goal_facts=report.details["goal"], log=report.details["log"],
                  failed=[s for s in report.details["steps"] if not s["ok"]])
    return summarise(record, every)


def summarise(record: dict[str, Any], every: int) -> dict[str, Any]:
    """The push's numbers along its line (from the object's start to its target)."""
    steps = record.pop("steps")
    if "start_xy" not in record or not steps:
        return record
    start, goal = np.asarray(record["start_xy"]), np.asarray(record["goal"])
    direction = (goal - start) / np.linalg.norm(goal - start)
    normal = np.array([-direction[1], direction[0]])

    def along(xy: np.ndarray) -> tuple[float, float]:
        rel = np.asarray(xy[:2]) - start
        return float(rel @ direction), float(rel @ normal)

    obj = np.array([along(np.asarray(s["obj"])) for s in steps])
    hand = np.array([along(np.asarray(s["hand"])) for s in steps])
    touching = [i for i, s in enumerate(steps) if s["contacts"]]
    planned = np.array([along(np.asarray(h)) for h in record["planned_hand"]])
    push_log = next((e for e in record["log"] if e.get("action") == "push"), {})
    record.update({
        "push_length_m": float(np.linalg.norm(goal - start)),
        "planned_hand_along_m": [float(planned[:, 0].min()), float(planned[:, 0].max())],
        "planned_hand_off_line_max_m": float(np.abs(planned[:, 1]).max()),
        "executed_hand_off_line_max_m": float(np.abs(hand[:, 1]).max()),
        "object_off_line_max_m": float(np.abs(obj[:, 1]).max()),
        "object_final_along_m": float(obj[-1, 0]),
        "object_final_off_line_m": float(obj[-1, 1]),
        "object_yaw_max_rad": float(np.abs([s["yaw"] for s in steps]).max()),
        "object_tilt_max_rad": float(np.abs([s["tilt"] for s in steps]).max()),
        "contact_links": sorted({k for s in steps for k in s["links"]}),
        "steps_touching": len(touching),
        "steps_two_finger_contact": sum(set(s["links"]) >= {9, 10} for s in steps),
        "hand_to_object_along_m_in_contact": float(np.median(obj[touching, 0]
                                                             - hand[touching, 0]))
        if touching else None,
        "push_error_m": push_log.get("error_m"),
        "finger_gap_m": push_log.get("finger_gap_m"),
        "trajectory_every": every,
        "trajectory": [{"step": i, "obj_along_m": round(obj[i, 0], 4),
                        "obj_off_line_m": round(obj[i, 1], 4),
                        "hand_along_m": round(hand[i, 0], 4),
                        "yaw_rad": round(steps[i]["yaw"], 3), "links": steps[i]["links"]}
                       for i in range(0, len(steps), every)],
    })
    return record


def reach_map(n: int) -> dict[str, Any]:
    """The push paths of arm r1 to an ``n`` x ``n`` grid of bowl targets (module docstring)."""
    import math

    from ltamp_cli.backends.pybullet.robot.arm import PANDA_HOME
    from ltamp_cli.backends.pybullet.robot.cartesian import follow_tool_path
    from ltamp_cli.backends.pybullet.robot.pose import Pose
    from ltamp_cli.backends.pybullet.tamp import skill_paths
    from ltamp_cli.backends.pybullet.tamp.planning import PlanningWorld
    from ltamp_cli.backends.pybullet.tamp.scene import scene_from_world
    from ltamp_cli.planner.problem import load_problem

    problem = load_problem(PROBLEM)
    spec = scene_from_world(problem.world)
    bowl = spec.objects["bowl"]
    start = tuple(float(v) for v in problem.objects["pbowl"][1])
    area = spec.regions["middle"]
    r = bowl.footprint()[0]
    xs = np.linspace(area.x[0] + r, area.x[1] - r, n) if area.x[1] - area.x[0] > 2 * r \
        else np.array([(area.x[0] + area.x[1]) / 2])
    ys = np.linspace(area.y[0] + r, area.y[1] - r, n) if area.y[1] - area.y[0] > 2 * r \
        else np.array([(area.y[0] + area.y[1]) / 2])
    planning = PlanningWorld(spec)
    arm = planning.scene.arms[1]
    base = planning.base_xy(1)
    yaws = {"across": 0.0, "across_turned": math.pi, "along": math.pi / 2}
    rows = []
    try:
        for gx in xs:
            for gy in ys:
                goal = (float(gx), float(gy))
                heading = math.atan2(goal[1] - start[1], goal[0] - start[0])
                row: dict[str, Any] = {"goal": [round(goal[0], 4), round(goal[1], 4)]}
                for name, offset in yaws.items():
                    yaw = heading + offset
                    poses = skill_paths.push_hand_poses(bowl, start, goal, planning.table_z, yaw)
                    gap = skill_paths.push_hand_gap(bowl, start, goal, yaw)
                    end = poses[2].position
                    c0 = time.process_time()
                    arm.set_configuration(np.asarray(PANDA_HOME))
                    arm.set_finger_opening(gap)
                    home = follow_tool_path(arm, poses, Pose(), np.random.default_rng(0),
                                            is_valid=planning.checker(1),
                                            config=planning.cartesian)
                    arm.open_gripper()
                    c1 = time.process_time()
                    fixed = planning.follow_hand_path(poses, 1, np.random.default_rng(0), "push",
                                                      touching="bowl", finger_gap=gap)
                    row[name] = {
                        "finger_gap_m": gap,
                        "hand_end_from_base_m": round(math.hypot(end[0] - base[0],
                                                                 end[1] - base[1]), 4),
                        "from_home": home.status, "from_home_failed_at": home.failed_index,
                        "waypoints": len(home.tool_poses),
                        "from_home_cpu_s": round(c1 - c0, 3),
                        "planning_world": fixed is not None,
                        "planning_world_cpu_s": round(time.process_time() - c1, 3)}
                rows.append(row)
                print(row["goal"], {k: (row[k]["from_home"], row[k]["planning_world"])
                                    for k in yaws}, file=sys.stderr)
    finally:
        planning.close()
    counts = {name: {"targets": len(rows),
                     "from_home": sum(r[name]["from_home"] == "solved" for r in rows),
                     "planning_world": sum(r[name]["planning_world"] for r in rows)}
              for name in yaws}
    return {"benchmark": "push_reach_map", "start": list(start), "grid": n,
            "found": counts, "targets": rows}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--fingers", choices=("auto", "closed", "open"), default="auto")
    parser.add_argument("--max-time", type=float, default=600.0)
    parser.add_argument("--every", type=int, default=100, help="trajectory stride (steps)")
    parser.add_argument("--pour-trials", type=int, default=0,
                        help="also run the plan's pour control as its skill trial, N seeds")
    parser.add_argument("--no-execute", action="store_true", help="plan (and pour trials) only")
    parser.add_argument("--reach-map", type=int, default=0, metavar="N",
                        help="no planning: arm r1's push paths to an N x N grid of targets")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    if args.max_time <= 0 or args.every <= 0 or args.seed < 0 or args.reach_map < 0:
        print("error: --max-time and --every must be positive, --seed and --reach-map >= 0",
              file=sys.stderr)
        return 2
    if args.reach_map:
        summary = reach_map(args.reach_map)
        print(json.dumps(summary["found"], indent=1))
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(summary, indent=1) + "\n")
        return 0
    record = run(args.seed, args.fingers, args.max_time, args.every, args.pour_trials,
                 not args.no_execute)
    print(json.dumps({k: v for k, v in record.items()
                      if k not in ("trajectory", "planned_hand", "log")}, indent=1))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(record, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
