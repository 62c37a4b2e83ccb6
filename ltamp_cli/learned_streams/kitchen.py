"""``GoodPour`` and ``GoodScoop``: learned streams for the Kitchen2D pour and scoop skills.

Contexts follow the skills' specs: pour ``(cup_width, cup_height, target_width,
target_height)``, scoop ``(cup_width, cup_height)``. By default the outputs are
``(control tuple, path)`` where the path is the object's waypoints relative to the target
cup's rim centre: pour ``((rel_x, rel_y, 0), (rel_x, rel_y, dangle))`` (x, y, tilt);
scoop the three spoon waypoints ``(x_i, y_i)`` scaled by the cup's width/height. A domain with
its own geometry passes its own ``to_context`` (from its own stream inputs), ``to_outputs``
and per-input hard test ``validity_for`` (see :class:`LearnedStream`); the Kitchen2D domain
(``domains/kitchen2d/streams.py``) does.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ltamp_cli.learned_streams.stream import LearnedStream, LearnedStreamConfig, ModelCache
from ltamp_cli.sampling.superlevel import PhysicalValidity

Size = Sequence[float]  # (width, height) of a cup in world units

#: The Kitchen2D skills' parameter names (``ltamp_cli/backends/box2d``): a model given to
#: these streams must be of that skill (``tests/robustness/test_learned_stream_models.py``
#: checks them against the backend).
POUR_NAMES = (("cup_width", "cup_height", "target_width", "target_height"),
              ("grasp_ratio", "rel_x", "rel_y", "dangle"))
SCOOP_NAMES = (("cup_width", "cup_height"),
               ("grasp_ratio", "x1", "y1", "x2", "y2", "x3", "y3"))
PUSH_NAMES = (("goal_x", "goal_y"), ("rx", "ry", "angle", "duration"))


def _pour_context(source: Size, target: Size) -> np.ndarray:
    return np.array([source[0], source[1], target[0], target[1]], dtype=float)


def _pour_outputs(control: np.ndarray, source: Size, target: Size) -> tuple[Any, ...]:
    _grasp, rel_x, rel_y, dangle = (float(v) for v in control)
    path = ((rel_x, rel_y, 0.0), (rel_x, rel_y, dangle))
    return (tuple(float(v) for v in control), path)


def _scoop_context(cup: Size) -> np.ndarray:
    return np.array([cup[0], cup[1]], dtype=float)


def _scoop_outputs(control: np.ndarray, cup: Size) -> tuple[Any, ...]:
    points = np.asarray(control[1:], dtype=float).reshape(3, 2) * [cup[0] / 2.0, cup[1]]
    path = tuple((float(x), float(y)) for x, y in points)
    return (tuple(float(v) for v in control), path)


class GoodPour(LearnedStream):
    """Inputs ``(source size, target size)`` -> outputs ``(control, pour path)``."""

    def __init__(self, config: LearnedStreamConfig, rng: np.random.Generator,
                 to_outputs: Callable[..., tuple[Any, ...] | None] = _pour_outputs,
                 is_valid: PhysicalValidity | None = None,
                 models: ModelCache | None = None, *,
                 to_context: Callable[..., np.ndarray] = _pour_context,
                 validity_for: Callable[..., PhysicalValidity | None] | None = None,
                 rng_for: Callable[..., np.random.Generator] | None = None) -> None:
        super().__init__(config, to_context, to_outputs, rng, is_valid, models, validity_for,
                         context_names=POUR_NAMES[0], control_names=POUR_NAMES[1],
                         rng_for=rng_for)


class GoodScoop(LearnedStream):
    """Inputs ``(cup size,)`` -> outputs ``(control, spoon path)``."""

    def __init__(self, config: LearnedStreamConfig, rng: np.random.Generator,
                 to_outputs: Callable[..., tuple[Any, ...] | None] = _scoop_outputs,
                 is_valid: PhysicalValidity | None = None,
                 models: ModelCache | None = None, *,
                 to_context: Callable[..., np.ndarray] = _scoop_context,
                 validity_for: Callable[..., PhysicalValidity | None] | None = None,
                 rng_for: Callable[..., np.random.Generator] | None = None) -> None:
        super().__init__(config, to_context, to_outputs, rng, is_valid, models, validity_for,
                         context_names=SCOOP_NAMES[0], control_names=SCOOP_NAMES[1],
                         rng_for=rng_for)
