"""Fixtures for the learning tests: single-threaded torch and the synthetic backend."""

from __future__ import annotations

import pytest
import torch

from ltamp_cli.backends import load_backend


@pytest.fixture(autouse=True, scope="session")
def _single_thread() -> None:
    torch.set_num_threads(1)


@pytest.fixture(scope="session")
def synthetic():
    backend = load_backend("synthetic")
    yield backend
    backend.close()
