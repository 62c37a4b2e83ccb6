"""Python bindings of the kitchen3d streams (PyBullet Kitchen3D geometry + GoodPour).

The scene's shapes come from ``world`` (:mod:`ltamp_cli.backends.pybullet.tamp.scene`);
movable objects' poses are planner values ``(x, y)``. One headless PyBullet world per
planning run answers IK, motion and collision queries
(:class:`~ltamp_cli.backends.pybullet.tamp.planning.PlanningWorld`).

GoodPour is learned: ``world.learned_streams.sample-pour`` (``model`` relative to this
folder; default ``../../models/kitchen3d/pour`` with the ``adaptive`` sampler) yields
controls from the GP level-set model's confident set, each passing the skill's geometric
pre-check; each control's cup path is followed by the arm (``follow-obj-path``) or skipped.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.backends.pybullet.skills.pour import pour_is_valid
from ltamp_cli.backends.pybullet.tamp.planning import PlanningWorld
from ltamp_cli.backends.pybullet.tamp.scene import scene_from_world
from ltamp_cli.backends.pybullet.tamp.skill_paths import pour_context, pour_tool_poses
from ltamp_cli.backends.pybullet.tamp.values import ArmConf, ArmPath, GraspValue, as_conf
from ltamp_cli.learned_streams.stream import LearnedStream, learned_stream_configs
from ltamp_cli.planner.streams import Binding, StreamInfo

HERE = Path(__file__).resolve().parent
#: Controls a GoodPour call tries before reporting "nothing this call".
POUR_TRIES_PER_CALL = 8
DEFAULT_LEARNED = {"sample-pour": {"model": "../../models/kitchen3d/pour", "sampler": "adaptive"}}


def _xy(value: Any) -> tuple[float, float]:
    return (round(float(value[0]), 4), round(float(value[1]), 4))


def make_streams(world: Mapping[str, Any], rng: np.random.Generator) -> dict[str, Any]:
    scene = scene_from_world(world)
    planning = PlanningWorld(scene)
    learned = {**DEFAULT_LEARNED, **dict(world.get("learned_streams", {}) or {})}
    configs = learned_stream_configs({"learned_streams": learned}, HERE)
    table_z = planning.table_z
    motion_seed = iter(range(1, 1_000_000))

    def sample_placement(name: str, region: str) -> Iterator[tuple[tuple[float, float]]]:
        area = scene.regions[region]
        half = scene.object(name).footprint()
        if area.x[1] - area.x[0] < 2 * half[0] or area.y[1] - area.y[0] < 2 * half[1]:
            return
        while True:
            yield ((round(float(rng.uniform(area.x[0] + half[0], area.x[1] - half[0])), 4),
                    round(float(rng.uniform(area.y[0] + half[1], area.y[1] - half[1])), 4)),)

    def sample_grasp(name: str) -> Iterator[tuple[GraspValue]]:
        for value in planning.grasp_values(name):
            yield (value,)

    def inverse_kinematics(name: str, pose: Any, grasp: GraspValue
                           ) -> Iterator[list[tuple[ArmConf, ArmPath]]]:
        yield list(planning.pick_kinematics(name, _xy(pose), tuple(grasp), rng))  # type: ignore[arg-type]

    def plan_free_motion(q1: ArmConf, q2: ArmConf) -> tuple[ArmPath] | None:
        path = planning.plan_motion(as_conf(q1), as_conf(q2), None, next(motion_seed))
        return None if path is None else (path,)

    def plan_holding_motion(name: str, grasp: GraspValue, q1: ArmConf, q2: ArmConf
                            ) -> tuple[ArmPath] | None:
        path = planning.plan_motion(as_conf(q1), as_conf(q2), (name, tuple(grasp)),  # type: ignore[arg-type]
                                    next(motion_seed))
        return None if path is None else (path,)

    def pour_outputs(control: np.ndarray, cup: str, grasp: GraspValue, bowl: str, pose: Any
                     ) -> tuple[Any, ...] | None:
        g: GraspValue = tuple(grasp)  # type: ignore[assignment]
        context = pour_context(scene.object(cup), scene.object(bowl))
        # The skill's pre-check (~50 ms) runs on the sampled control only, not inside the
        # sampler on its thousands of candidates; None makes the learned stream draw again.
        if not bool(pour_is_valid(context, control[None, :])[0]):
            return None
        for arm in range(scene.n_arms):
            for psi, phi in planning.skill_yaws(cup, g, arm):
                poses = pour_tool_poses(scene.object(cup), scene.object(bowl), _xy(pose),
                                        table_z, control, psi, phi)
                path = planning.follow_object_path(cup, g, poses, arm, rng, "pour")
                if path is not None:
                    return (path.start, path, tuple(round(float(v), 6) for v in control))
        # Not None: the learned stream would silently draw again; an empty tuple lets the
        # planner's call end ("nothing this call") and try other streams meanwhile.
        return ()

    learned_streams: dict[str, LearnedStream] = {}

    def pour_stream() -> LearnedStream:
        if "sample-pour" not in learned_streams:  # the model is loaded on first use only
            learned_streams["sample-pour"] = LearnedStream(
                configs["sample-pour"],
                lambda cup, grasp, bowl, pose: pour_context(scene.object(cup),
                                                            scene.object(bowl)),
                pour_outputs, rng)
        return learned_streams["sample-pour"]

    def pour_feedback(inputs: tuple[Any, ...], outputs: tuple[Any, ...]) -> None:
        if "sample-pour" in learned_streams:
            learned_streams["sample-pour"].on_unusable(inputs, outputs)

    def sample_pour(cup: str, grasp: GraspValue, bowl: str, pose: Any
                    ) -> Iterator[list[tuple[Any, ...]]]:
        if scene.object(cup).kind != "cup" or scene.object(bowl).kind not in ("bowl", "cup"):
            return
        misses = 0
        for outputs in pour_stream()(cup, grasp, bowl, pose):
            if outputs:
                misses = 0
                yield [outputs]
            else:
                misses += 1
                # Most confident controls often put the hand into the bowl's rim: try a few
                # per call so that one call usually succeeds, but give the planner back
                # control now and then.
                if misses % POUR_TRIES_PER_CALL == 0:
                    yield []

    def test_cfree(a: str, pa: Any, b: str, pb: Any) -> bool:
        return not planning.footprints_overlap(a, _xy(pa), b, _xy(pb))

    def test_cfree_traj(path: ArmPath, name: str, pose: Any) -> bool:
        return not planning.path_collides(path, name, _xy(pose))

    def distance(q1: ArmConf, q2: ArmConf) -> float:
        return round(1.0 + float(np.linalg.norm(as_conf(q1).array - as_conf(q2).array)), 4)

    return {
        "sample-placement": Binding(sample_placement, StreamInfo(overhead=0.01)),
        "sample-grasp": Binding(sample_grasp, StreamInfo(overhead=0.01)),
        "inverse-kinematics": Binding(inverse_kinematics, StreamInfo(p_success=0.5,
                                                                     overhead=0.1)),
        "plan-free-motion": Binding(plan_free_motion, StreamInfo(overhead=0.2)),
        "plan-holding-motion": Binding(plan_holding_motion, StreamInfo(overhead=0.2)),
        "sample-pour": Binding(sample_pour, StreamInfo(p_success=0.5, overhead=1.0),
                               on_unusable=pour_feedback),
        "test-cfree": Binding(test_cfree, StreamInfo(eager=True, overhead=0.001)),
        "test-cfree-traj": Binding(test_cfree_traj, StreamInfo(eager=True, overhead=0.01)),
        "distance": distance,
    }


__all__ = ["make_streams"]
