"""``make_sampler`` (the Python API behind ``ltamp sample`` and learned streams) refuses a
context it cannot sample for, as the CLI does, instead of an empty sampler (NaN: before the
fix ``next()`` raised a bare StopIteration) or a numpy reshape error (wrong length)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ltamp_cli.backends import load_backend
from ltamp_cli.learning.gp import fit_gp
from ltamp_cli.learning.model import LevelSetModel
from ltamp_cli.sampling.factory import make_sampler


@pytest.fixture(scope="module")
def model() -> Iterator[Any]:
    backend = load_backend("synthetic")
    try:
        spec = backend.skills()["moving2d"]
    finally:
        backend.close()
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, size=(30, 3))
    yield LevelSetModel(spec, fit_gp(x, 0.5 - np.abs(x[:, 0]), rng=rng))


@pytest.mark.parametrize("context, expected", [
    ([float("nan")], "not finite"), ([float("inf")], "not finite"),
    ([0.3, 0.4], "context has 2 value(s)"), ([], "context has 0 value(s)")])
def test_bad_context_is_one_value_error(model: Any, context: list[float],
                                        expected: str) -> None:
    with pytest.raises(ValueError, match=expected.replace("(", r"\(").replace(")", r"\)")):
        make_sampler("adaptive", model, np.array(context), np.random.default_rng(0))


def test_good_context_samples(model: Any, tmp_path: Path) -> None:
    sampler = make_sampler("adaptive", model, np.array([0.3]), np.random.default_rng(0))
    controls = np.array([next(sampler) for _ in range(5)])
    assert controls.shape == (5, 2) and np.all(np.isfinite(controls))
