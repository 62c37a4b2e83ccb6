"""Fixtures for the sampling tests: GP models fitted once on the synthetic skills' true scores."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from ltamp_cli.backends import load_backend
from ltamp_cli.learning.baselines import RandomModel
from ltamp_cli.learning.gp import fit_gp
from ltamp_cli.learning.model import LevelSetModel


@pytest.fixture(autouse=True, scope="session")
def _single_thread() -> None:
    torch.set_num_threads(1)


@pytest.fixture(scope="session")
def synthetic():
    backend = load_backend("synthetic")
    yield backend
    backend.close()


def fit_dense(backend, skill: str, n: int, seed: int, kernel: str = "matern52") -> LevelSetModel:
    """A GP on ``n`` uniform trials of ``skill`` (true scores, invalid ones scored −1)."""
    spec = backend.skills()[skill]
    rng = np.random.default_rng(seed)
    contexts = spec.context.sample_uniform(rng, n)
    controls = spec.control.sample_uniform(rng, n)
    template = RandomModel(spec, 0.0)  # coordinates only
    x = template.to_unit(contexts, controls)
    y = backend.true_score(skill, contexts, controls)
    gp = fit_gp(x, y, kernel, restarts=1, rng=np.random.default_rng(seed))
    return LevelSetModel(spec, gp)


@pytest.fixture(scope="session")
def fit():
    """:func:`fit_dense` as a fixture (test modules do not import the conftest)."""
    return fit_dense


@pytest.fixture(scope="session")
def moving2d_model(synthetic) -> LevelSetModel:
    """Densely trained: 250 trials in a 3-D input space."""
    return fit_dense(synthetic, "moving2d", 250, seed=1)


@pytest.fixture(scope="session")
def skill8d_model(synthetic) -> LevelSetModel:
    """100 trials of the 8-D skill (with its invalid corner)."""
    return fit_dense(synthetic, "skill8d", 100, seed=2)


@pytest.fixture(scope="session")
def toy1d_model(synthetic) -> LevelSetModel:
    return fit_dense(synthetic, "toy1d", 40, seed=3)
