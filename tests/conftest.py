"""Shared test configuration: single-threaded numerics, repo paths."""

from __future__ import annotations

import os

# Must happen before numpy/torch are imported by any test module.
for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import importlib.util  # noqa: E402
from collections.abc import Callable, Iterator  # noqa: E402
from pathlib import Path  # noqa: E402
from types import ModuleType  # noqa: E402
from typing import Any  # noqa: E402

import pytest  # noqa: E402

REPO_ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="session")
def repo_root() -> Path:
    return REPO_ROOT


@pytest.fixture(autouse=True)
def _private_cache_dir(tmp_path_factory: pytest.TempPathFactory,
                       monkeypatch: pytest.MonkeyPatch) -> None:
    """Keep anything written to the user cache (e.g. planner statistics) out of $HOME."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path_factory.mktemp("xdg-cache")))


def _load_bindings(relative: str) -> ModuleType:
    """A fresh copy of a bindings module (``relative`` to the repository root)."""
    name = "bindings_under_test_" + relative.replace("/", "_").removesuffix(".py")
    spec = importlib.util.spec_from_file_location(name, REPO_ROOT / relative)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="session")
def load_bindings() -> Callable[[str], ModuleType]:
    return _load_bindings


def _first_output_digests(generator: Iterator[Any], n: int, calls: int = 40) -> list[int]:
    """Content digests (``key_digest``) of a stream generator's first ``n`` output tuples,
    over at most ``calls`` calls (a call yields a tuple or a list of them): outputs holding
    arrays compare by contents."""
    from ltamp_cli.planner.keyed_random import key_digest

    found: list[Any] = []
    for _ in range(calls):
        batch = next(generator, None)
        if batch is None:
            break
        found.extend(batch if isinstance(batch, list) else [batch])
        if len(found) >= n:
            break
    return [key_digest(outputs) for outputs in found[:n]]


@pytest.fixture(scope="session")
def first_outputs() -> Callable[..., list[int]]:
    return _first_output_digests
