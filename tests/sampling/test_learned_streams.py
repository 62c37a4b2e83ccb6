"""Learned streams: model cached, YAML config, and a planning problem solved through one."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from ltamp_cli.errors import InputError
from ltamp_cli.learned_streams.kitchen import GoodScoop
from ltamp_cli.learned_streams.stream import LearnedStream, LearnedStreamConfig, ModelCache
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.sampling.kernel_learning import load_kernel

EXAMPLE = "problems/examples/synthetic_goodregion.yaml"


def _problem_with_model(repo_root: Path, tmp_path: Path, model_dir: Path, sampler: str,
                        blocked: list[float] | None = None) -> Path:
    """The example problem, pointed at ``model_dir`` (absolute paths, written to tmp)."""
    data = yaml.safe_load((repo_root / EXAMPLE).read_text())
    data["domain"] = str(repo_root / "domains/synthetic_goodregion")
    data["bindings"] = str(repo_root / "domains/synthetic_goodregion/streams.py")
    entry = data["world"]["learned_streams"]["sample-good-control"]
    entry.update(model=str(model_dir), sampler=sampler,
                 kernel_file=str(tmp_path / "kernel.json"))
    if blocked is not None:
        data["world"]["blocked_x"] = blocked
    path = tmp_path / "problem.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.fixture(scope="module")
def goodregion_model(moving2d_model, tmp_path_factory) -> Path:
    directory = tmp_path_factory.mktemp("model")
    moving2d_model.save(str(directory))
    return directory


@pytest.mark.parametrize("sampler", ["adaptive", "diverse-lk"])
def test_learned_stream_solves_the_goodregion_problem(
    repo_root, tmp_path, synthetic, goodregion_model, sampler: str
) -> None:
    path = _problem_with_model(repo_root, tmp_path, goodregion_model, sampler)
    problem = load_problem(path)
    result = solve(problem, PlannerConfig(algorithm="focused", max_time=60, seed=0))
    assert result.status == "solved"
    assert sorted(step.values[0] for step in result.plan) == [0.15, 0.25]
    for step in result.plan:
        phase, (x, y) = step.values
        assert x > 3.0  # clear of the blocked band
        score = synthetic.true_score("moving2d", np.array([phase]), np.array([[x, y]]))[0]
        assert score > 0.0
    streams = result.stats["streams"]
    # θ* of both tasks lies in the blocked band: some learned samples failed downstream
    assert streams["test-clear"]["calls"] > 2
    kernel_file = tmp_path / "kernel.json"
    if sampler == "diverse-lk":
        kernel = load_kernel(kernel_file, synthetic.skills()["moving2d"])
        assert kernel.updates >= 1 and kernel.inverse_lengthscales.min() < 1.0
    else:
        assert not kernel_file.exists()


def test_learned_kernel_persists_across_tasks(repo_root, tmp_path, synthetic,
                                              goodregion_model) -> None:
    path = _problem_with_model(repo_root, tmp_path, goodregion_model, "diverse-lk")
    updates = []
    for seed in range(4):
        result = solve(load_problem(path), PlannerConfig(max_time=60, seed=seed))
        assert result.status == "solved"
        updates.append(load_kernel(tmp_path / "kernel.json",
                                   synthetic.skills()["moving2d"]).updates)
    # Each solve starts from the kernel the earlier ones left and adds its own feedback (a
    # solve may report no unusable sample): the count never drops and grows past the
    # first solve's. A kernel learned afresh per solve would restart from zero.
    assert 1 <= updates[0] < updates[-1]
    assert updates == sorted(updates)


def test_unreachable_region_is_not_solved(repo_root, tmp_path, goodregion_model) -> None:
    # every good control is blocked: the planner must not return a plan
    path = _problem_with_model(repo_root, tmp_path, goodregion_model, "adaptive", [0.0, 4.0])
    result = solve(load_problem(path), PlannerConfig(max_time=3, seed=0))
    assert result.status != "solved"


def test_model_is_loaded_once_and_feedback_reaches_the_sampler(goodregion_model) -> None:
    cache = ModelCache()
    config = LearnedStreamConfig(goodregion_model, "diverse-lk",
                                 kernel_file=goodregion_model / "k.json")
    stream = LearnedStream(config, lambda phase: np.array([phase]),
                           lambda control, phase: (tuple(control.tolist()),),
                           np.random.default_rng(0), models=cache)
    again = LearnedStream(config, lambda phase: np.array([phase]),
                          lambda control, phase: (tuple(control.tolist()),),
                          np.random.default_rng(1), models=cache)
    assert stream.model is again.model
    generator = stream(0.5)
    outputs = [next(generator) for _ in range(3)]
    stream.on_unusable((0.5,), outputs[2])
    assert stream.n_unusable == 1 and stream.kernel is not None and stream.kernel.updates == 1
    assert (goodregion_model / "k.json").exists()
    stream.on_unusable((0.5,), ((9.0, 9.0),))  # not an output of this stream: ignored
    assert stream.n_unusable == 1


def test_bad_learned_stream_settings(tmp_path, goodregion_model, moving2d_model) -> None:
    with pytest.raises(InputError, match="unknown sampler 'mcmc'"):
        LearnedStreamConfig.from_mapping({"model": "m", "sampler": "mcmc"}, tmp_path, "w.s")
    with pytest.raises(InputError, match="unknown field 'modle'"):
        LearnedStreamConfig.from_mapping({"modle": "m"}, tmp_path, "w.s")
    with pytest.raises(InputError, match="lambda: expected a number"):
        LearnedStreamConfig.from_mapping({"model": "m", "lambda": "x"}, tmp_path, "w.s")
    config = LearnedStreamConfig.from_mapping({"model": "nowhere"}, tmp_path, "w.s")
    with pytest.raises(InputError, match="model directory"):
        LearnedStream(config, np.array, lambda c: (c,), np.random.default_rng(0))
    # a kernel file learned for another skill is refused
    (tmp_path / "k.json").write_text(
        '{"format": "ltamp-diversity-kernel", "version": 1, "skill": "pour", '
        '"controls": ["a"], "inverse_lengthscales": [1.0]}'
    )
    config = LearnedStreamConfig(goodregion_model, "diverse-lk", kernel_file=tmp_path / "k.json")
    with pytest.raises(InputError, match="not 'moving2d'"):
        LearnedStream(config, np.array, lambda c: (c,), np.random.default_rng(0))


def test_default_kernel_lives_in_the_user_cache_not_the_model(
    repo_root, tmp_path, synthetic, goodregion_model, monkeypatch
) -> None:
    """Without ``kernel_file`` the learned kernel goes to the user cache, keyed by the model's
    weights digest (copies of one model share it); the model directory is left untouched."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    path = _problem_with_model(repo_root, tmp_path, goodregion_model, "diverse-lk")
    data = yaml.safe_load(path.read_text())
    data["world"]["learned_streams"]["sample-good-control"]["kernel_file"] = None
    path.write_text(yaml.safe_dump(data))
    before = sorted(p.name for p in goodregion_model.iterdir())
    assert solve(load_problem(path), PlannerConfig(max_time=60, seed=0)).status == "solved"
    assert sorted(p.name for p in goodregion_model.iterdir()) == before
    kernels = list((tmp_path / "cache" / "ltamp" / "diversity-kernels").glob("*/*.json"))
    assert len(kernels) == 1
    assert load_kernel(kernels[0], synthetic.skills()["moving2d"]).updates >= 1
    copy = tmp_path / "copy"
    copy.mkdir()
    for item in goodregion_model.iterdir():
        (copy / item.name).write_bytes(item.read_bytes())
    assert LearnedStreamConfig(copy, "diverse-lk").kernel_path == kernels[0]


def test_good_scoop_outputs_a_path_inside_the_cup(synthetic, fit, tmp_path) -> None:
    from ltamp_cli.backends.protocol import ParamSpace, SkillSpec
    from ltamp_cli.learning.gp import fit_gp
    from ltamp_cli.learning.model import LevelSetModel

    # A stand-in scoop model with the Kitchen2D scoop spec (no physics needed for the mapping).
    spec = SkillSpec("scoop", ParamSpace(("cup_width", "cup_height"), (5.0, 4.0), (10.0, 8.0)),
                     ParamSpace(("grasp_ratio", "x1", "y1", "x2", "y2", "x3", "y3"),
                                (0.0, -1, 0, -1, 0, -1, 0), (1.0, 1, 1, 1, 1, 1, 1)))
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, (60, 9))
    y = 0.8 - np.linalg.norm(x[:, :7], axis=1)
    LevelSetModel(spec, fit_gp(x, y, restarts=0)).save(str(tmp_path / "scoop"))
    stream = GoodScoop(LearnedStreamConfig(tmp_path / "scoop", "adaptive"), rng)
    control, path = next(stream((6.0, 5.0)))
    assert len(control) == 7 and len(path) == 3
    assert all(abs(px) <= 3.0 and 0.0 <= py <= 5.0 for px, py in path)


def test_validity_for_inputs_is_part_of_the_sampled_set(goodregion_model) -> None:
    """A per-input hard test (here: x above a threshold given as a stream input) holds for
    every yielded control of every sampler, the sampler's θ* included; a test no control
    passes ends the call at once."""
    for sampler in ("rejection", "adaptive", "diverse", "diverse-lk"):
        config = LearnedStreamConfig(goodregion_model, sampler,
                                     kernel_file=goodregion_model / f"{sampler}.json")
        stream = LearnedStream(
            config, lambda phase, x_min: np.array([phase]),
            lambda control, phase, x_min: (tuple(control.tolist()),),
            np.random.default_rng(0),
            validity_for=lambda phase, x_min: (
                lambda context, controls: controls[:, 0] > x_min))
        made = stream.sampler_for(0.25, 3.0)
        star = made.superlevel.to_physical(made.superlevel.theta_star)[0]
        assert star[0] > 3.0  # (without the test, θ* lies at x < 3: see the problem above)
        generator = stream(0.25, 3.0)
        outputs = [next(generator)[0] for _ in range(20)]
        assert all(x > 3.0 for x, _ in outputs), sampler
        assert list(stream(0.25, 1e9)) == []  # nothing valid: no endless search
