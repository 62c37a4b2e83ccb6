"""Bindings of the slide domain: ``sample-push`` is a learned stream of the ``push`` skill.

A target object's value is its distance (the skill's context); the stream's output is a
speed drawn from the model named by ``world.learned_streams.sample-push``.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.errors import InputError
from ltamp_cli.learned_streams.stream import LearnedStream, learned_stream_configs
from ltamp_cli.planner.streams import StreamInfo

HERE = Path(__file__).resolve().parent
STREAM = "sample-push"


def make_streams(world: Mapping[str, Any], rng: np.random.Generator) -> dict[str, Any]:
    configs = learned_stream_configs(world, HERE)
    if STREAM not in configs:
        raise InputError(f"world.learned_streams: missing the {STREAM!r} entry")

    def to_context(target: float) -> np.ndarray:
        return np.array([float(target)])

    def to_outputs(control: np.ndarray, target: float) -> tuple[float]:
        return (round(float(control[0]), 6),)

    learned = LearnedStream(configs[STREAM], to_context, to_outputs, rng)
    return {STREAM: learned.binding(StreamInfo(p_success=0.9))}
