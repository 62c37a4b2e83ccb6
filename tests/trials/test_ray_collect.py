"""``ltamp collect --ray``: a local Ray cluster writes the same resumable file as local workers."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

from ltamp_cli.trials.collect import CollectJob, collect
from ltamp_cli.trials.record import TrialDataset, TrialRecord

ENV_THREADS = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
ENV = {**os.environ, **ENV_THREADS}


def _comparable(record: TrialRecord) -> tuple:
    return (record.index, record.context, record.control, record.score, record.valid, record.seed)


def _ltamp(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "ltamp_cli", *args],
        env=env or ENV,
        capture_output=True,
        text=True,
        timeout=240,
    )


@pytest.mark.slow
@pytest.mark.skipif(importlib.util.find_spec("ray") is None, reason="needs the ltamp[ray] extra")
def test_ray_local_cluster_resumes_and_matches_serial(tmp_path: Path) -> None:
    n, seed = 12, 4
    serial, distributed = tmp_path / "serial.jsonl", tmp_path / "ray.jsonl"
    job = CollectJob(skill="skill8d", backend="synthetic", n=n, seed=seed)
    assert collect(job, serial, workers=1, progress=False) == n
    # A partial file, as a killed earlier run leaves it: trials 0..3 plus a torn last line.
    partial_job = CollectJob(skill="skill8d", backend="synthetic", n=4, seed=seed)
    assert collect(partial_job, distributed, workers=1, progress=False) == 4
    before = distributed.read_bytes()
    with distributed.open("ab") as handle:
        handle.write(b'{"skill": "skill8d", "index": 7, "sco')

    done = _ltamp(
        "collect", "skill8d", "--backend", "synthetic", "-n", str(n), "--seed", str(seed),
        "--ray", "local", "--workers", "2", "--out", str(distributed),
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-2000:]
    assert f"{n - 4} new trials" in done.stderr
    assert distributed.read_bytes().startswith(before)  # kept verbatim, torn tail dropped
    records = TrialDataset(distributed).read()
    assert sorted(r.index for r in records) == list(range(n))  # nothing lost or duplicated
    expected = sorted(map(_comparable, TrialDataset(serial).read()))
    assert sorted(map(_comparable, records)) == expected
    # Nothing left: a rerun adds nothing and does not even start Ray.
    again = _ltamp(
        "collect", "skill8d", "--backend", "synthetic", "-n", str(n), "--seed", str(seed),
        "--ray", "local", "--out", str(distributed),
    )  # fmt: skip
    assert again.returncode == 0 and "0 new trials" in again.stderr
    assert len(TrialDataset(distributed).read()) == n


def test_ray_missing_is_one_line_exit_2(tmp_path: Path) -> None:
    # A package named ``ray`` that fails to import stands in for an install without the extra.
    fake = tmp_path / "fake" / "ray"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text("raise ImportError('No module named ray')\n")
    env = {**ENV, "PYTHONPATH": os.pathsep.join([str(fake.parent), ENV.get("PYTHONPATH", "")])}
    out = tmp_path / "t.jsonl"
    done = _ltamp(
        "collect", "toy1d", "--backend", "synthetic", "-n", "2", "--ray", "local",
        "--out", str(out), env=env,
    )  # fmt: skip
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "ltamp[ray]" in lines[0], done.stderr
    assert "Traceback" not in done.stderr
    assert not out.exists() or not TrialDataset(out).read()


def test_ray_empty_address_is_rejected(tmp_path: Path) -> None:
    done = _ltamp(
        "collect", "toy1d", "--backend", "synthetic", "-n", "2", "--ray", " ",
        "--out", str(tmp_path / "t.jsonl"),
    )  # fmt: skip
    assert done.returncode == 2 and "--ray" in done.stderr and "Traceback" not in done.stderr


@pytest.mark.skipif(importlib.util.find_spec("ray") is None, reason="needs the ltamp[ray] extra")
def test_ray_unreachable_address_fails_fast(tmp_path: Path) -> None:
    out = tmp_path / "t.jsonl"
    done = _ltamp(
        "collect", "toy1d", "--backend", "synthetic", "-n", "2", "--ray", "127.0.0.1:1",
        "--out", str(out),
    )  # fmt: skip
    assert done.returncode == 2, done.stderr[-2000:]
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "cannot reach a Ray cluster at '127.0.0.1:1'" in lines[0]
    assert not out.exists()


@pytest.mark.slow
@pytest.mark.skipif(importlib.util.find_spec("ray") is None, reason="needs the ltamp[ray] extra")
def test_ray_joins_a_running_cluster_by_address(tmp_path: Path) -> None:
    import logging

    import ray

    ray.init(
        num_cpus=2, include_dashboard=False, log_to_driver=False, logging_level=logging.ERROR,
        object_store_memory=100 * 1024 * 1024,
    )  # fmt: skip
    try:
        address = ray.get_runtime_context().gcs_address
        out = tmp_path / "t.jsonl"
        # ray.init sets the cluster's auth settings (RAY_AUTH_MODE...) in os.environ.
        done = _ltamp(
            "collect", "moving2d", "--backend", "synthetic", "-n", "6", "--seed", "1",
            "--ray", address, "--out", str(out), env={**os.environ, **ENV_THREADS},
        )  # fmt: skip
        assert done.returncode == 0, done.stderr[-2000:]
        # The cluster belongs to someone else: the collection leaves it running.
        assert ray.cluster_resources().get("CPU") == 2
    finally:
        ray.shutdown()
    serial = tmp_path / "serial.jsonl"
    collect(CollectJob("moving2d", "synthetic", 6, seed=1), serial, progress=False)
    a = sorted(map(_comparable, TrialDataset(out).read()))
    assert a == sorted(map(_comparable, TrialDataset(serial).read())) and len(a) == 6
