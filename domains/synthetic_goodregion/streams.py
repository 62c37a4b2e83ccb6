"""Bindings of the synthetic good-region domain: a learned stream plus a downstream test.

A task's value is its context (the ``moving2d`` skill's ``phase``); a control is ``(x, y)``.
``sample-good-control`` is a :class:`~ltamp_cli.learned_streams.stream.LearnedStream` set up
by ``world.learned_streams.sample-good-control`` (relative model paths are resolved against
this folder). ``test-clear`` rejects controls whose ``x`` lies in ``world.blocked_x``
(``[low, high]``), a region the learned model does not know: the planner reports those
controls unusable, which is what the ``diverse-lk`` sampler learns from.

The shipped model (``model/``) was made with::

    ltamp train moving2d --backend synthetic --strategy lse2 --budget 60 --seed 0 \
        --out domains/synthetic_goodregion/model
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.backends.synthetic import SyntheticBackend
from ltamp_cli.errors import InputError
from ltamp_cli.learned_streams.stream import LearnedStream, learned_stream_configs
from ltamp_cli.planner.streams import Binding, StreamInfo

HERE = Path(__file__).resolve().parent
STREAM = "sample-good-control"


def make_streams(world: Mapping[str, Any], rng: np.random.Generator) -> dict[str, Any]:
    configs = learned_stream_configs(world, HERE)
    if STREAM not in configs:
        raise InputError(f"world.learned_streams: missing the {STREAM!r} entry")
    blocked = world.get("blocked_x", [0.0, 0.0])
    if not (isinstance(blocked, list) and len(blocked) == 2):
        raise InputError("world.blocked_x: expected [low, high]")
    low, high = float(blocked[0]), float(blocked[1])

    def to_context(phase: float) -> np.ndarray:
        return np.array([float(phase)])

    def to_outputs(control: np.ndarray, phase: float) -> tuple[tuple[float, float]]:
        return ((float(control[0]), float(control[1])),)

    # skill=: a model of another skill, or one trained on other bounds, is refused in one
    # line when the stream is built (without it only the sizes are checked, on first use)
    learned = LearnedStream(configs[STREAM], to_context, to_outputs, rng,
                            skill=SyntheticBackend().skills()["moving2d"])

    def test_clear(phase: float, control: tuple[float, float]) -> bool:
        return not low <= control[0] <= high

    return {
        STREAM: learned.binding(StreamInfo(p_success=0.9)),
        "test-clear": Binding(test_clear, StreamInfo(eager=True)),
    }
