"""KeyedRandom: draws fixed by the key, not by what was drawn before."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys

import numpy as np
import pytest

from ltamp_cli.planner.keyed_random import KeyedRandom, key_digest


@dataclasses.dataclass(frozen=True)
class _Conf:
    arm: int
    q: tuple[float, ...]


def _draws(generator: np.random.Generator) -> list[float]:
    return generator.uniform(size=5).tolist()


def test_a_key_draws_the_same_whatever_ran_before() -> None:
    first = KeyedRandom(np.random.default_rng(3))
    alone = _draws(first("sample-pose", "cup", (0.25, -0.5)))
    second = KeyedRandom(np.random.default_rng(3))
    for i in range(50):  # other instances draw first, as many times as they like
        _draws(second("sample-pose", "bowl", (float(i), 0.0)))
    assert _draws(second("sample-pose", "cup", (0.25, -0.5))) == alone


def test_keys_and_seeds_give_independent_draws() -> None:
    keyed = KeyedRandom(np.random.default_rng(3))
    base = _draws(keyed("motion", _Conf(0, (0.0, 1.0)), 0))
    assert _draws(keyed("motion", _Conf(0, (0.0, 1.0)), 1)) != base
    assert _draws(keyed("motion", _Conf(1, (0.0, 1.0)), 0)) != base
    assert _draws(keyed("motion", _Conf(0, (0.0, 1.000001)), 0)) != base
    other_seed = KeyedRandom(np.random.default_rng(4))
    assert _draws(other_seed("motion", _Conf(0, (0.0, 1.0)), 0)) != base
    # many keys: the first draws look uniform (no key collapses onto another)
    firsts = np.array([keyed("k", i).uniform() for i in range(2000)])
    assert abs(firsts.mean() - 0.5) < 0.03 and len(set(firsts.tolist())) == 2000


def test_equal_values_key_alike() -> None:
    assert key_digest(1.0, (2, "a")) == key_digest(np.float64(1.0), [np.int64(2), "a"])
    assert key_digest(np.array([0.5, -0.0])) == key_digest(np.array([0.5, 0.0]))
    assert key_digest({"b": 1, "a": 2}) == key_digest({"a": 2, "b": 1})
    assert key_digest("1") != key_digest(1)


def test_the_digest_is_the_same_in_every_process() -> None:
    code = ("from ltamp_cli.planner.keyed_random import key_digest;"
            "print(key_digest('sample-pour', 'cup', (0.1, 0.2), {'x': 'y'}))")
    outputs = set()
    for salt in ("1", "2"):  # str hashes differ per PYTHONHASHSEED; the digest must not
        env = {**os.environ, "PYTHONHASHSEED": salt}
        outputs.add(subprocess.run([sys.executable, "-c", code], env=env, check=True,
                                   capture_output=True, text=True).stdout.strip())
    assert outputs == {str(key_digest("sample-pour", "cup", (0.1, 0.2), {"x": "y"}))}


def test_a_value_keyed_by_its_address_is_refused() -> None:
    with pytest.raises(TypeError, match="no stable representation"):
        key_digest(object())


def test_seed_is_a_non_negative_int_fixed_by_the_key() -> None:
    keyed = KeyedRandom(np.random.default_rng(0))
    seed = keyed.seed("motion", 3)
    assert isinstance(seed, int) and 0 <= seed < 2**31
    assert seed == keyed.seed("motion", 3) and seed != keyed.seed("motion", 4)
