"""``ltamp skills``, ``ltamp train`` and ``ltamp evaluate`` end to end (synthetic backend)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ltamp_cli.cli.app import main
from ltamp_cli.trials.record import TrialDataset, TrialRecord


def run(capsys, *argv: str) -> tuple[int, str, str]:
    with pytest.raises(SystemExit) as done:
        main(list(argv))
    captured = capsys.readouterr()
    return int(done.value.code or 0), captured.out, captured.err


def test_skills_json_lists_synthetic_skills_with_bounds(capsys):
    code, out, _ = run(capsys, "skills", "--json")
    assert code == 0
    backends = {b["name"]: b for b in json.loads(out)["backends"]}
    assert {"synthetic", "box2d", "pybullet", "sapien"} <= set(backends)
    skills = {s["name"]: s for s in backends["synthetic"]["skills"]}
    assert [p["name"] for p in skills["moving2d"]["control"]] == ["x", "y"]
    assert skills["moving2d"]["control"][0]["high"] == 4.0
    assert [p["name"] for p in skills["skill8d"]["context"]] == ["a0", "a1", "a2", "a3"]
    for backend in backends.values():
        assert backend["available"] or backend["error"]


def test_train_then_evaluate(capsys, tmp_path):
    out = tmp_path / "model"
    code, stdout, _ = run(
        capsys,
        "train",
        "--json",
        "moving2d",
        "--backend",
        "synthetic",
        "--strategy",
        "lse2",
        "--budget",
        "40",
        "--kernel",
        "mlp",
        "--seed",
        "1",
        "--out",
        str(out),
        "--eval-every",
        "20",
        "--curve",
        str(tmp_path / "curve.png"),
    )
    assert code == 0
    summary = json.loads(stdout)
    assert summary["n_trials"] == 40 and summary["kind"] == "gp"
    assert (tmp_path / "curve.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert len(TrialDataset(out / "trials.jsonl").read()) == 40
    code, stdout, _ = run(capsys, "evaluate", str(out), "--json", "--trials", "10")
    assert code == 0
    report = json.loads(stdout)
    assert report["f1"] > 0.8 and report["success_rate"] >= 0.9
    assert report["f1"] == pytest.approx(summary["f1"], abs=0.1)
    low, high = report["success_rate_wilson95"]  # 10 contexts: a rate with its uncertainty
    assert low < report["success_rate"] <= high and high - low > 0.15


def test_train_pool_mode_from_a_dataset(capsys, tmp_path, synthetic):
    spec = synthetic.skills()["moving2d"]
    rng = np.random.default_rng(0)
    contexts, controls = (
        spec.context.sample_uniform(rng, 300),
        spec.control.sample_uniform(rng, 300),
    )
    scores = synthetic.true_score("moving2d", contexts, controls)
    data = tmp_path / "pool.jsonl"
    TrialDataset(data).append(
        TrialRecord("moving2d", tuple(c), tuple(u), float(s), True, i, "synthetic", index=i)
        for i, (c, u, s) in enumerate(zip(contexts, controls, scores, strict=True))
    )
    code, stdout, _ = run(
        capsys,
        "train",
        "--json",
        "moving2d",
        "--strategy",
        "rf-r",
        "--budget",
        "100",
        "--data",
        str(data),
        "--out",
        str(tmp_path / "rf"),
    )
    assert code == 0 and json.loads(stdout)["kind"] == "rf-r"
    metadata = json.loads((tmp_path / "rf" / "model.json").read_text())
    assert metadata["training"]["mode"] == "pool" and metadata["training"]["n_trials"] == 100
    code, stdout, _ = run(
        capsys, "evaluate", str(tmp_path / "rf"), "--json", "--trials", "5", "--data", str(data)
    )
    assert code == 0 and json.loads(stdout)["n_test"] == 300


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["train", "moving2d", "--strategy", "magic", "--out", "{tmp}/m"], "strategy"),
        (["train", "nope", "--out", "{tmp}/m"], "no skill 'nope'"),
        (["train", "moving2d", "--backend", "sapien", "--out", "{tmp}/m"], "sapien"),
        (["evaluate", "{tmp}"], "model.json"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(capsys, tmp_path, argv, message):
    code, _, err = run(capsys, *[a.format(tmp=tmp_path) for a in argv])
    assert code == 2
    assert message in err and err.count("\n") == 1 and "Traceback" not in err
