"""Kitchen2D Tasks I and III: pushing a block off the table past a curb (learned GoodPush)
and picking a pitcher out of a U-shaped holder."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ltamp_cli.backends.box2d.backend import Kitchen2DBackend
from ltamp_cli.backends.box2d.gripper import body_pose
from ltamp_cli.backends.box2d.scene import build_scene, default_grasp, scene_from_world
from ltamp_cli.backends.box2d.tamp import KitchenGeometry, section_mask
from ltamp_cli.backends.execution import execute_plan
from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError
from ltamp_cli.learning.model import LevelSetModel
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem

ROOT = Path(__file__).resolve().parents[2]
TASK1 = ROOT / "problems" / "kitchen2d" / "task1_push_off.yaml"
TASK3 = ROOT / "problems" / "kitchen2d" / "task3_holder_pour.yaml"
PUSH_MODEL = ROOT / "models" / "kitchen2d" / "push"


def _task1(seed: int, **changes: Any) -> tuple[Any, KitchenGeometry, str]:
    """Task I's scene for ``seed`` (world keys overridden by ``changes``), its geometry and
    the side of the curb (``left`` / ``right`` of the block)."""
    world = {**load_problem(TASK1).world, **changes}
    spec = scene_from_world(world, np.random.default_rng(seed))
    home = spec.object("block").home
    side = ("right" if spec.walls[0][0] > home else "left") if spec.walls else ""
    return spec, KitchenGeometry(spec), side


def test_curb_side_is_drawn_by_the_seed_and_blocks_the_pick_and_that_way() -> None:
    sides = {_task1(seed)[2] for seed in range(1, 11)}
    assert sides == {"left", "right"}
    for seed in (1, 6):
        spec, geometry, side = _task1(seed)
        block = spec.object("block")
        pose = (block.home, geometry.top)
        # No finger fits between the block and the curb: the pick has no free approach...
        assert geometry.kinematics("block", pose, default_grasp(block)) is None
        # ...while the same block without the curb could be picked.
        _, bare, _ = _task1(seed, curbs={})
        assert bare.kinematics("block", pose, default_grasp(block)) is not None
        # The block can only slide away from the curb.
        away = "left_edge" if side == "right" else "right_edge"
        towards = "right_edge" if side == "right" else "left_edge"
        assert geometry.push_path_clear("block", pose, away)
        assert not geometry.push_path_clear("block", pose, towards)


def test_push_setup_runs_the_skill_push_along_the_table_clear_of_the_curb() -> None:
    spec, geometry, side = _task1(1)
    assert side == "right"
    pose = (spec.object("block").home, geometry.top)
    context = geometry.push_context("block", pose, "left_edge")
    assert context is not None and context[0] < -2.0 and context[1] == 0.0
    good = np.array([2.0, 0.0, np.pi, 0.6])  # start right of the block, push left 6 units
    conf, (above, start, end) = geometry.push_setup("block", pose, "left_edge", good)
    assert conf == above and start[0] > pose[0] and end[0] == pytest.approx(start[0] - 6.0)
    # The fingertips pass over the curb (0.25 high) but hit the block (0.6 high).
    tip = start[1] - spec.gripper.tip
    assert geometry.top + 0.25 < tip < geometry.top + 0.6
    # Pushing away from the edge, or from the wrong side, is no push off that edge.
    assert geometry.push_setup("block", pose, "left_edge", [2.0, 0.0, 0.0, 0.6]) is None
    assert geometry.push_setup("block", pose, "left_edge", [-2.0, 0.0, np.pi, 0.6]) is None
    # Out of the skill's reach: a goal past an edge more than 5 units away.
    far = (pose[0] + 3.0, pose[1])
    assert geometry.push_context("block", far, "left_edge") is None
    mask = section_mask(context, np.array([good, [2.0, 2.0, np.pi, 0.6],
                                           [2.0, 0.0, np.pi / 2, 0.6]]))
    assert mask.tolist() == [True, False, False]


def test_goodpush_yields_pushes_that_succeed_in_skill_trials_and_takes_feedback() -> None:
    """Task I's learned stream (shipped push model): its first push succeeds in a real push
    trial, the model's least confident in-section push fails, the curb side yields nothing,
    and the planner's unusable feedback reaches the stream."""
    problem = load_problem(TASK1)
    seed = 1
    streams = problem.streams_factory(dict(problem.world), np.random.default_rng(seed))
    spec, geometry, side = _task1(seed)
    assert side == "right"
    binding = streams["sample-push"]
    assert list(binding.function("block", "p_block", "right_edge")) == []
    outputs = next(binding.function("block", "p_block", "left_edge"))
    conf, approach, control = outputs
    assert approach[0] == conf and approach[2][0] < approach[1][0]
    pose = (spec.object("block").home, geometry.top)
    context = geometry.push_context("block", pose, "left_edge")
    backend = Kitchen2DBackend()
    assert backend.run_trial("push", context, np.array(control), 0).score > 0
    model = LevelSetModel.load(str(PUSH_MODEL))
    candidates = model.spec.control.sample_uniform(np.random.default_rng(0), 4000)
    candidates = candidates[backend.is_valid("push", context, candidates)
                            & section_mask(context, candidates)]
    mean, std = model.predict(np.repeat(context[None], len(candidates), 0), candidates)
    worst = candidates[np.argmin(mean / std)]
    assert backend.run_trial("push", context, worst, 0).score < 0
    stream = binding.on_unusable.__self__
    assert stream.n_unusable == 0
    binding.on_unusable(("block", "p_block", "left_edge"), outputs)
    assert stream.n_unusable == 1


def test_holder_hugs_the_pitcher_so_only_high_grasps_are_free() -> None:
    problem = load_problem(TASK3)
    spec = scene_from_world(problem.world, np.random.default_rng(1))
    (holder,) = spec.holders
    pitcher = spec.object("pitcher")
    (_, l1), (r0, _) = holder.walls()
    bar_left = pitcher.home + pitcher.spec.handle_x - pitcher.spec.handle_width / 2
    # Walls: left one closer to the handle than a finger is wide, right one beside the cup.
    assert 0 < bar_left - l1 < spec.gripper.finger_width
    assert 0 < r0 - (pitcher.home + pitcher.spec.width / 2) < 0.3
    geometry = KitchenGeometry(spec)
    bare = KitchenGeometry(dataclasses.replace(spec, holders=()))
    pose = (pitcher.home, geometry.top)
    low = (pitcher.spec.handle_x, pitcher.spec.grasp_height(0.2))
    high = (pitcher.spec.handle_x, pitcher.spec.grasp_height(0.65))
    assert geometry.kinematics("pitcher", pose, low) is None
    assert geometry.kinematics("pitcher", pose, high) is not None
    assert bare.kinematics("pitcher", pose, low) is not None
    # In Box2D the pitcher stands still in its holder (one static U-shaped body).
    live = build_scene(spec, 1)
    kinds = [b.userData.get("name") for b in live.kitchen.world.bodies if b.userData]
    assert kinds.count("holder") == 1
    live.kitchen.step(100)
    x, y, angle = body_pose(live.bodies["pitcher"])
    assert abs(x - pitcher.home) < 0.05 and abs(y - geometry.top) < 0.05 and abs(angle) < 0.01


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"curbs": {"teapot": {}}}, "curbs: unknown object"),
        ({"curbs": {"block": {"side": "up"}}}, "curbs.block.side"),
        ({"curbs": {"block": {"height": -1}}}, "curbs.block"),
        ({"holders": {"block": {"height": 1.0}}}, "holders.block: only cups"),
        ({"curbs": ["block"]}, "curbs: expected a mapping"),
    ],
)
def test_bad_curbs_and_holders_are_input_errors(changes: dict, message: str) -> None:
    world = {**load_problem(TASK1).world, **changes}
    with pytest.raises(InputError, match=re.escape(message)):
        scene_from_world(world, np.random.default_rng(0))
    bad_height = {**load_problem(TASK3).world, "holders": {"pitcher": {"height": 8.0}}}
    with pytest.raises(InputError, match=r"holders\.pitcher\.height"):
        scene_from_world(bad_height, np.random.default_rng(0))


def test_task1_block_is_pushed_off_the_table_away_from_the_curb(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    problem = load_problem(TASK1)
    result = solve(problem, PlannerConfig(max_time=60, seed=1))
    assert result.solved
    names = [step.name for step in result.plan]
    assert "push" in names and "pick" not in names
    gif = tmp_path / "task1.gif"
    report = execute_plan("box2d", problem, result, 1, gif)
    assert report.success and report.goal_holds, report.details
    spec, geometry, side = _task1(1)
    (push,) = [entry for entry in report.details["log"] if "push" in entry]
    end_x, end_y = push["end"]
    assert end_y < geometry.top - 1.0
    # The curb is right of the block for seed 1: the block went over the left edge.
    assert side == "right" and end_x < spec.layout.table_x0
    assert gif.stat().st_size > 0
    # The goal is read from the world, not the plan: the same push without its stroke (the
    # pusher never moves) leaves the block on the table. (A stroke cut to a fraction is not
    # enough: where the plan's block sits at the edge, any contact tips it over.)
    step = result.plan[-1]
    conf, start, _ = step.values[4]
    short = (conf, start, start)
    control = (*step.values[5][:3], 0.0)
    cut = dataclasses.replace(step, values=(*step.values[:4], short, control))
    report = execute_plan("box2d", problem, dataclasses.replace(
        result, plan=[*result.plan[:-1], cut]), 1)
    assert not report.goal_holds
    assert not report.details["goal"]["(offtable block)"]["holds"]
    assert "push block" in report.details["error"]
    # The command line plans, executes and renders the same task.
    out_gif = tmp_path / "cli.gif"
    with pytest.raises(SystemExit) as done:
        main(["solve", str(TASK1), "--seed", "6", "--backend", "box2d", "--render",
              str(out_gif)])
    out = capsys.readouterr().out
    assert done.value.code == 0, out
    assert "push block p_block right_edge" in out  # seed 6: the curb is on the left
    assert "executed: True  goal_holds: True" in out
    assert out_gif.stat().st_size > 0


@pytest.mark.slow
def test_task3_pitcher_is_picked_high_out_of_its_holder_and_poured(tmp_path: Path) -> None:
    problem = load_problem(TASK3)
    result = solve(problem, PlannerConfig(max_time=60, seed=1))
    assert result.solved
    assert [step.name for step in result.plan] == ["move-free", "pick", "move-holding",
                                                  "pour"]
    spec = scene_from_world(problem.world, np.random.default_rng(1))
    (holder,) = spec.holders
    grasp = result.plan[1].values[2]
    # The fingertips stay above the holder's walls.
    assert grasp[1] - spec.gripper.tip > holder.height
    gif = tmp_path / "task3.gif"
    report = execute_plan("box2d", problem, result, 1, gif)
    assert report.success and report.goal_holds, report.details
    water = report.details["goal"]["(contains cup water)"]
    assert water["inside"] >= water["needed"] >= 0.9 * 200
    particles = report.details["particles"]
    assert particles["n_particles"] == particles["n_expected"] == particles["n_in_world"]
    assert gif.stat().st_size > 0


def test_a_hand_going_into_the_holder_fails_the_pick_physically() -> None:
    """Box2D lets the kinematic hand pass through static bodies; the executor checks the
    hand against walls and holders itself. A low grasp the planner would reject goes into
    the holder's wall; the planned high grasp does not."""
    problem = load_problem(TASK3)
    result = solve(problem, PlannerConfig(max_time=60, seed=1))
    assert result.solved
    move, pick = result.plan[:2]
    assert (move.name, pick.name) == ("move-free", "pick")
    prefix = dataclasses.replace(result, plan=[move, pick])
    assert execute_plan("box2d", problem, prefix, 1).success
    spec = scene_from_world(problem.world, np.random.default_rng(1))
    pitcher = spec.object("pitcher").spec
    low = (pitcher.handle_x, pitcher.grasp_height(0.1))
    conf, grasp_point = pick.values[4]
    approach = (conf, (grasp_point[0], grasp_point[1] - pick.values[2][1] + low[1]))
    bad = dataclasses.replace(pick, values=(*pick.values[:2], low, pick.values[3], approach))
    report = execute_plan("box2d", problem, dataclasses.replace(result, plan=[move, bad]), 1)
    assert not report.success
    assert "went into the holder" in report.details["error"]
