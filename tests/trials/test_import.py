"""``ltamp import``: validation, round trip, deduplication, and training from imported trials."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError
from ltamp_cli.trials.importing import import_file, parse_trials
from ltamp_cli.trials.record import TrialDataset


@pytest.fixture(scope="module")
def synthetic():
    backend = load_backend("synthetic")
    yield backend
    backend.close()


def run(capsys, *argv: str) -> tuple[int, str, str]:
    with pytest.raises(SystemExit) as done:
        main(list(argv))
    captured = capsys.readouterr()
    return int(done.value.code or 0), captured.out, captured.err


def _true_rows(synthetic, n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    spec = synthetic.skills()["moving2d"]
    rng = np.random.default_rng(seed)
    contexts = spec.context.sample_uniform(rng, n)
    controls = spec.control.sample_uniform(rng, n)
    return contexts, controls, synthetic.true_score("moving2d", contexts, controls)


def _write_csv(path, contexts, controls, scores) -> None:
    lines = ["phase,x,y,score,valid,seed,operator"]
    for i, (c, u, s) in enumerate(zip(contexts, controls, scores, strict=True)):
        values = (float(c[0]), float(u[0]), float(u[1]), float(s))
        lines.append(",".join(map(repr, values)) + f",true,{i},alice")
    path.write_text("\n".join(lines) + "\n")


def test_csv_and_jsonl_round_trip_to_identical_records(synthetic, tmp_path):
    spec = synthetic.skills()["moving2d"]
    contexts, controls, scores = _true_rows(synthetic, 12, seed=1)
    _write_csv(tmp_path / "real.csv", contexts, controls, scores)
    with (tmp_path / "real.jsonl").open("w") as handle:
        for i, (c, u, s) in enumerate(zip(contexts, controls, scores, strict=True)):
            row = {"phase": c[0], "x": u[0], "y": u[1], "score": s, "valid": True, "seed": i}
            row = {k: v if isinstance(v, bool) else float(v) for k, v in row.items()}
            handle.write(json.dumps(row) + "\n")
    from_csv = parse_trials(tmp_path / "real.csv", spec)
    from_jsonl = parse_trials(tmp_path / "real.jsonl", spec)
    assert [(r.context, r.control, r.score, r.seed) for r in from_csv] == [
        (r.context, r.control, r.score, r.seed) for r in from_jsonl
    ]
    np.testing.assert_array_equal([r.control for r in from_csv], controls)
    np.testing.assert_array_equal([r.score for r in from_csv], scores)
    assert from_csv[0].backend == "import:real.csv"
    assert from_csv[3].info["line"] == 5


def test_cli_import_appends_once_and_skips_duplicates(capsys, synthetic, tmp_path):
    contexts, controls, scores = _true_rows(synthetic, 8, seed=2)
    _write_csv(tmp_path / "a.csv", contexts, controls, scores)
    out = tmp_path / "trials.jsonl"
    argv = ("import", "--json", str(tmp_path / "a.csv"), "--skill", "moving2d", "--out", str(out))
    code, stdout, _ = run(capsys, *argv)
    assert code == 0 and json.loads(stdout)["added"] == 8
    code, stdout, _ = run(capsys, *argv)
    assert code == 0
    assert json.loads(stdout) == {
        "out": str(out),
        "rows": 8,
        "added": 0,
        "skipped_duplicates": 8,
    }
    # A file overlapping the first in 3 rows adds only its 5 new rows.
    more_c, more_u, more_s = _true_rows(synthetic, 5, seed=3)
    _write_csv(
        tmp_path / "b.csv",
        np.vstack([contexts[:3], more_c]),
        np.vstack([controls[:3], more_u]),
        np.concatenate([scores[:3], more_s]),
    )
    code, stdout, _ = run(
        capsys, "import", "--json", str(tmp_path / "b.csv"), "--skill", "moving2d", "--out",
        str(out))
    assert code == 0 and json.loads(stdout)["added"] == 5
    assert len(TrialDataset(out).read()) == 13


@pytest.mark.parametrize(
    ("body", "expected"),
    [
        ("phase,x,score\n0.5,1.0,0.2\n", "a.csv:2:1: missing field 'y'"),
        ("phase,x,y,score\n0.5,abc,0.0,0.2\n", "a.csv:2:1: field 'x': expected a number"),
        ("phase,x,y,score\n0.5,1.0,0.0,1\n0.5,9.0,0.0,1\n", "a.csv:3:1: field 'x': 9 is outside"),
        ("phase,x,y,score\n0.5,1.0,0.0,nan\n", "field 'score': expected a finite number"),
        ("phase,x,y\n0.5,1.0,0.0\n", "a.csv:2:1: missing field 'score'"),
        ("phase,x,y,fraction\n0.5,1.0,0.0,0.3\n", "no score function for a measured fraction"),
        ("phase,x,y,score,valid\n0.5,1.0,0.0,1,maybe\n", "field 'valid': expected true/false"),
        ("phase,x,y,score\n0.5,1.0\n", "a.csv:2:1: row has 2 fields"),
    ],
)
def test_bad_rows_name_file_line_and_field(synthetic, tmp_path, body, expected):
    (tmp_path / "a.csv").write_text(body)
    out = tmp_path / "trials.jsonl"
    with pytest.raises(InputError) as error:
        import_file(tmp_path / "a.csv", synthetic.skills()["moving2d"], out)
    assert expected in str(error.value)
    assert not out.exists()  # nothing is written when any row is bad


def test_cli_bad_jsonl_exits_2_with_one_line(capsys, tmp_path):
    (tmp_path / "r.jsonl").write_text('{"phase": 0.5, "x": 1, "y": 0, "score": 1}\n[1, 2]\n')
    code, out, err = run(
        capsys,
        "import",
        str(tmp_path / "r.jsonl"),
        "--skill",
        "moving2d",
        "--out",
        str(tmp_path / "t.jsonl"),
    )
    assert code == 2 and out == ""
    assert err.strip().count("\n") == 0 and "r.jsonl:2:1: expected a JSON object" in err


def test_fraction_uses_the_backends_score_function(synthetic, tmp_path):
    (tmp_path / "a.csv").write_text("phase,x,y,fraction\n0.5,1.0,0.0,0.8\n0.5,1.0,0.1,0.2\n")
    records = parse_trials(
        tmp_path / "a.csv", synthetic.skills()["moving2d"], lambda skill, f: f - 0.5
    )
    assert [r.score for r in records] == pytest.approx([0.3, -0.3])


def _fraction_csv(path, spec, fractions) -> None:
    names = [*spec.context.names, *spec.control.names]
    middle = [(lo + hi) / 2 for lo, hi in zip((*spec.context.lows, *spec.control.lows),
                                              (*spec.context.highs, *spec.control.highs),
                                              strict=True)]
    rows = [",".join(map(str, [*middle, f])) for f in fractions]
    path.write_text(",".join([*names, "fraction"]) + "\n" + "\n".join(rows) + "\n")


@pytest.mark.parametrize(("backend_name", "skill", "expected"), [
    # 2D pour: exp(2(10x - 9.5)) - 1, > 0 iff x > 0.95; 2D scoop: x - 0.5.
    ("box2d", "pour", [np.exp(2 * (10 * x - 9.5)) - 1 for x in (0.2, 0.95, 1.0)]),
    ("box2d", "scoop", [-0.3, 0.45, 0.5]),
    # 3D: piecewise linear with tau 0.9 (pour) and 0.7 (scoop).
    ("pybullet", "pour", [0.2 / 0.9 - 1, 0.05 / 0.1, 1.0]),
    ("pybullet", "scoop", [0.2 / 0.7 - 1, 0.25 / 0.3, 1.0]),
])
def test_built_in_backends_score_measured_fractions(capsys, tmp_path, backend_name, skill,
                                                    expected):
    backend = load_backend(backend_name)
    try:
        spec = backend.skills()[skill]
    finally:
        backend.close()
    _fraction_csv(tmp_path / "r.csv", spec, (0.2, 0.95, 1.0))
    code, _, err = run(capsys, "import", str(tmp_path / "r.csv"), "--skill", skill,
                       "--backend", backend_name, "--out", str(tmp_path / "t.jsonl"))
    assert code == 0, err
    scores = [r.score for r in TrialDataset(tmp_path / "t.jsonl").read()]
    assert scores == pytest.approx(expected)


def test_a_fraction_for_a_skill_not_scored_by_one_is_one_line(capsys, tmp_path):
    backend = load_backend("box2d")
    try:
        spec = backend.skills()["push"]
    finally:
        backend.close()
    _fraction_csv(tmp_path / "r.csv", spec, (0.5,))
    code, out, err = run(capsys, "import", str(tmp_path / "r.csv"), "--skill", "push",
                         "--backend", "box2d", "--out", str(tmp_path / "t.jsonl"))
    assert code == 2 and out == ""
    assert err.strip().count("\n") == 0
    assert "r.csv:2:1" in err and "not scored from a measured fraction" in err


def test_train_data_learns_from_imported_trials(capsys, synthetic, tmp_path):
    from ltamp_cli.learning.metrics import SkillEvaluator
    from ltamp_cli.learning.model_dir import load_model

    contexts, controls, scores = _true_rows(synthetic, 300, seed=4)
    _write_csv(tmp_path / "real.csv", contexts, controls, scores)
    trials = tmp_path / "trials.jsonl"
    code, _, _ = run(
        capsys, "import", str(tmp_path / "real.csv"), "--skill", "moving2d", "--out", str(trials)
    )
    assert code == 0
    model_dir = tmp_path / "model"
    code, stdout, _ = run(
        capsys,
        "train",
        "--json",
        "moving2d",
        "--data",
        str(trials),
        "--budget",
        "50",
        "--out",
        str(model_dir),
    )
    assert code == 0 and json.loads(stdout)["n_trials"] == 50
    loaded = load_model(model_dir)
    assert loaded.metadata["training"]["mode"] == "pool"
    evaluator = SkillEvaluator.synthetic(synthetic, "moving2d", n_test=2000, seed=99)
    assert evaluator.heldout.f1(loaded.model) > 0.8
