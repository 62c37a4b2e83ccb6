"""Kitchen2D GoodPour / GoodScoop / GoodPush as generic learned streams: the kitchen's hard
tests run inside the sampler (vectorised, agreeing with the per-control tests), and a problem
YAML chooses each learned stream's model and sampler."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from ltamp_cli.backends.box2d import tamp_batch
from ltamp_cli.backends.box2d.scene import scene_from_world
from ltamp_cli.backends.box2d.skills import pour as pour_skill
from ltamp_cli.backends.box2d.skills import push as push_skill
from ltamp_cli.backends.box2d.skills import scoop as scoop_skill
from ltamp_cli.backends.box2d.tamp import KitchenGeometry
from ltamp_cli.errors import InputError
from ltamp_cli.learned_streams.kitchen import GoodPour, GoodScoop
from ltamp_cli.learning.model_dir import load_model
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.sampling.adaptive import AdaptiveSampler
from ltamp_cli.sampling.diverse import DiverseSampler
from ltamp_cli.sampling.factory import SAMPLER_NAMES, make_sampler
from ltamp_cli.sampling.rejection import RejectionSampler

ROOT = Path(__file__).resolve().parents[2]
PROBLEMS = ROOT / "problems" / "kitchen2d"
TASK2 = PROBLEMS / "task2_pour_wall.yaml"


def _uniform(spec: Any, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.uniform(np.array(spec.control.lows), np.array(spec.control.highs),
                       size=(n, spec.control.dim))


def test_batch_setup_tests_agree_with_the_per_control_tests() -> None:
    """pour_mask / scoop_mask / push_mask give the same verdict as pour_setup / scoop_setup /
    push_setup on random controls, in scenes with a wall (Task II), the coffee kitchen and
    both curb sides of Task I; each verdict is mixed (neither all pass nor all fail)."""
    for name, seed in (("task2_pour_wall", 0), ("coffee", 1)):
        scene = scene_from_world(load_problem(PROBLEMS / f"{name}.yaml").world,
                                 np.random.default_rng(seed))
        geometry = KitchenGeometry(scene)
        source = "cream" if name == "coffee" else "pitcher"
        controls = _uniform(pour_skill.SPEC, 300, seed)
        for pose in ((scene.object("cup").home, geometry.top),
                     geometry.placements("cup", "coaster")[0]):
            batch = tamp_batch.pour_mask(geometry, source, "cup", pose, controls)
            one = [geometry.pour_setup(source, "cup", pose, c) is not None for c in controls]
            assert batch.tolist() == one
            assert 0.1 < batch.mean() < 0.9
    scene = scene_from_world(load_problem(PROBLEMS / "coffee.yaml").world,
                             np.random.default_rng(1))
    geometry = KitchenGeometry(scene)
    pose = (scene.object("sugar").home, geometry.top)
    controls = _uniform(scoop_skill.SPEC, 300, 2)
    batch = tamp_batch.scoop_mask(geometry, "spoon", "sugar", pose, controls)
    assert batch.tolist() == [geometry.scoop_setup("spoon", "sugar", pose, c) is not None
                              for c in controls]
    assert 0.1 < batch.mean() < 0.99
    for seed in (0, 1):
        scene = scene_from_world(load_problem(PROBLEMS / "task1_push_off.yaml").world,
                                 np.random.default_rng(seed))
        geometry = KitchenGeometry(scene)
        pose = (scene.object("block").home, geometry.top)
        controls = _uniform(push_skill.SPEC, 300, seed)
        for edge in ("left_edge", "right_edge"):
            batch = tamp_batch.push_mask(geometry, "block", pose, edge, controls)
            assert batch.tolist() == [geometry.push_setup("block", pose, edge, c) is not None
                                      for c in controls]
            assert 0.05 < batch.mean() < 0.9


def _task2_streams(sampler: str, tmp_path: Path, seed: int = 0) -> dict[str, Any]:
    problem = load_problem(TASK2)
    world = dict(problem.world)
    entry = {**world["learned_streams"]["sample-pour"], "sampler": sampler,
             "kernel_file": str(tmp_path / f"{sampler}.json")}
    world["learned_streams"] = {"sample-pour": entry}
    return problem.streams_factory(world, np.random.default_rng(seed))


@pytest.mark.parametrize("sampler", SAMPLER_NAMES)
def test_every_sampler_yields_only_pours_the_kitchen_can_use(sampler: str,
                                                              tmp_path: Path) -> None:
    """Task II (cup beside a wall): without the kitchen's tests inside the sampler, a
    sampler's skill-valid confident pours still hit the wall, the table or graze the cup
    (20-47 % of 30 draws per sampler with the #20 model; before the skill's validity checked
    the tilt too, most of them: the reason the generic stream was once reverted); with them
    every yielded pour passes ``pour_setup`` and the stream never had to skip one."""
    seed = 0
    scene = scene_from_world(load_problem(TASK2).world, np.random.default_rng(seed))
    geometry = KitchenGeometry(scene)
    pose = (scene.object("cup").home, geometry.top)
    src, dst = scene.object("pitcher").spec, scene.object("cup").spec
    context = np.array([src.width, src.height, dst.width, dst.height])
    model = load_model(ROOT / "models" / "kitchen2d" / "pour").model
    config = pour_skill.PourConfig()
    plain = make_sampler(sampler, model, context, np.random.default_rng(0),
                         is_valid=lambda c, u: pour_skill.valid_mask(c, u, config))
    usable = np.mean([geometry.pour_setup("pitcher", "cup", pose, next(plain)) is not None
                      for _ in range(30)])
    assert usable < 0.9, usable

    binding = _task2_streams(sampler, tmp_path, seed)["sample-pour"]
    wired = binding.function.__self__
    stream = wired.stream
    assert isinstance(stream, GoodPour) and stream.config.sampler == sampler
    pours = binding.function("pitcher", "cup", "p_cup", "table")
    outputs = [next(pours) for _ in range(12)]
    for grasp, conf, approach, control in outputs:
        setup = geometry.pour_setup("pitcher", "cup", pose, np.array(control))
        assert setup is not None  # (outputs round controls to 1e-6: compare to 1e-3)
        assert np.allclose(np.concatenate([grasp, conf, *approach]),
                           np.concatenate([setup[0], setup[1], *setup[2]]), atol=1e-3)
    assert stream.n_samples == 12
    assert all(count == 0 for count in wired.rejected.values())
    assert len({o[-1] for o in outputs}) == 12  # no repeats


def test_yaml_chooses_each_learned_streams_sampler(tmp_path: Path) -> None:
    expected = {"rejection": RejectionSampler, "adaptive": AdaptiveSampler,
                "diverse": DiverseSampler, "diverse-lk": DiverseSampler}
    for sampler, kind in expected.items():
        binding = _task2_streams(sampler, tmp_path)["sample-pour"]
        stream = binding.function.__self__.stream
        made = stream.sampler_for("pitcher", "cup", "p_cup", "table")
        assert type(made) is kind
        assert (stream.kernel is not None) == (sampler == "diverse-lk")
    # The older form names the models only (world.models): default samplers.
    coffee = load_problem(PROBLEMS / "coffee.yaml")
    world = {key: value for key, value in coffee.world.items() if key != "learned_streams"}
    world["models"] = {"pour": "../../models/kitchen2d/pour",
                       "scoop": "../../models/kitchen2d/scoop"}
    streams = coffee.streams_factory(world, np.random.default_rng(0))
    scoop = streams["sample-scoop"].function.__self__.stream
    assert isinstance(scoop, GoodScoop) and scoop.config.sampler == "diverse"
    assert scoop.config.model_dir == (ROOT / "models" / "kitchen2d" / "scoop").resolve()


def _written(tmp_path: Path, change: dict[str, Any]) -> Path:
    data = yaml.safe_load(TASK2.read_text())
    data["domain"] = str(ROOT / "domains" / "kitchen2d")
    data["bindings"] = str(ROOT / "domains" / "kitchen2d" / "streams.py")
    data["world"].update(change)
    path = tmp_path / "task2.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


@pytest.mark.parametrize(("change", "message"), [
    ({"learned_streams": {"sample-pour": {"model": "../../models/kitchen2d/pour",
                                          "sampler": "gibbs"}}},
     r"task2\.yaml:\d+:\d+: .*learned_streams\.sample-pour\.sampler"),
    ({"learned_streams": {"sample-puor": {"model": "../../models/kitchen2d/pour"}}},
     r"task2\.yaml:\d+:\d+: world\.learned_streams\.sample-puor: the stream file has no "
     r"stream 'sample-puor'"),
    ({"learned_streams": {"sample-pour": {"model": "../../models/kitchen2d/nowhere"}}},
     r"world\.learned_streams\.sample-pour\.model: no model directory"),
    ({"models": {"pour": "../../models/kitchen2d/pour"}},
     r"world\.models\.pour: the model of sample-pour is also given"),
])
def test_bad_learned_stream_entries_are_one_line_input_errors(
        tmp_path: Path, change: dict[str, Any], message: str) -> None:
    with pytest.raises(InputError, match=message) as raised:
        problem = load_problem(_written(tmp_path, change))
        problem.streams_factory(dict(problem.world), np.random.default_rng(0))
    assert "\n" not in str(raised.value)


def test_kernel_learning_bench_plans_tasks_1_to_3_with_each_sampler(tmp_path: Path) -> None:
    """The paper's kernel-learning table switches the learned streams of Tasks I–III
    through their YAMLs: each variant's bindings really use that sampler and keep the
    learned kernel in the bench's folder, not next to the shipped model."""
    # bench/ is not installed: the repository root must be importable (as tests/bench's
    # conftest arranges for its own tests).
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    from bench.paper.kernel_learning import PROBLEMS, SAMPLERS, sampler_variants

    tasks = [(label, path) for label, path, _, _ in PROBLEMS if "kitchen2d" in path]
    assert [label for label, _ in tasks] == ["Task I", "Task II", "Task III"]
    for label, path in tasks:
        variants = sampler_variants(load_problem(ROOT / path), tmp_path, label)
        assert variants is not None and set(variants) == set(SAMPLERS)
        for sampler, problem in variants.items():
            streams = problem.streams_factory(dict(problem.world), np.random.default_rng(0))
            name = "sample-push" if label == "Task I" else "sample-pour"
            stream = streams[name].function.__self__.stream
            assert stream.config.sampler == sampler
            assert stream.config.kernel_path.parent == tmp_path


def test_push_model_is_confident_only_on_the_strip_the_sampling_table_uses() -> None:
    """Why the sampling table's push row draws goals on the push model's strip (where it is
    trained densely: a quarter of its goals): on the strip the most confident in-section
    push succeeds (goals (-4.5, 0) and (4.5, 0)); off it, for goal (2.7, -3.9), it fails in
    a real push trial. The model before issue #20's noise cap was misleading there (its μ/σ
    was higher than on the strip); since the cap it is less confident there than on it."""
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    from bench.paper.sampling_table import LiveScores, _push_strip
    from ltamp_cli.backends import load_backend
    from ltamp_cli.backends.box2d.tamp import section_mask
    from ltamp_cli.sampling.superlevel import build_superlevel_set

    strip = _push_strip("models/kitchen2d/push")
    assert strip is not None
    assert {key: strip[key] for key in ("goal_x_abs", "goal_y_abs_max")} == {
        "goal_x_abs": [3.0, 5.0], "goal_y_abs_max": 0.5}
    backend = load_backend("box2d")
    try:
        scores = LiveScores(backend, "push", strip)
        rng = np.random.default_rng(0)
        goals = np.array([scores.sample_context("push", rng) for _ in range(50)])
        assert ((np.abs(goals[:, 0]) >= 3.0) & (np.abs(goals[:, 0]) <= 5.0)).all()
        assert (np.abs(goals[:, 1]) <= 0.5).all() and (goals[:, 0] < 0).any()
        model = load_model(ROOT / "models" / "kitchen2d" / "push").model
        phi = {}
        for goal, succeeds in (((2.7, -3.88), False), ((-4.5, 0.0), True), ((4.5, 0.0), True)):
            context = np.array(goal)
            level = build_superlevel_set(
                model, context, np.random.default_rng(1),
                is_valid=lambda c, u: scores.is_valid("push", c, u))
            star = level.to_physical(level.theta_star)
            assert section_mask(context, star)[0]
            phi[goal] = level.phi_star
            score = backend.run_trial("push", context, star[0], 4242).score
            assert (score > 0) == succeeds, (goal, score)
        assert phi[(2.7, -3.88)] < min(phi[(-4.5, 0.0)], phi[(4.5, 0.0)])
    finally:
        backend.close()
