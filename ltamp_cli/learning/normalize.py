"""Affine maps between a physical box and the learner's cube ``[-1, 1]^d``.

Every learner in :mod:`ltamp_cli.learning` works on *normalised* inputs. The GP input order is
``[control..., context...]`` (the paper's ``(θ, α)``): :func:`joint_space` builds that box from
a :class:`~ltamp_cli.backends.protocol.SkillSpec` and :class:`BoxNormalizer` maps it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ltamp_cli.backends.protocol import ParamSpace, SkillSpec


@dataclass(frozen=True)
class BoxNormalizer:
    """Min-max map of the box ``[lows, highs]`` (physical units) onto ``[-1, 1]^d``.

    A degenerate dimension (``low == high``) maps to 0 and back to its one value.
    """

    lows: tuple[float, ...]
    highs: tuple[float, ...]

    @staticmethod
    def for_space(space: ParamSpace) -> BoxNormalizer:
        return BoxNormalizer(tuple(space.lows), tuple(space.highs))

    @property
    def dim(self) -> int:
        return len(self.lows)

    def _center_half_width(self) -> tuple[np.ndarray, np.ndarray]:
        lows = np.asarray(self.lows, dtype=float)
        highs = np.asarray(self.highs, dtype=float)
        half = (highs - lows) / 2.0
        return (highs + lows) / 2.0, half

    def to_unit(self, x: np.ndarray) -> np.ndarray:
        """Physical ``(..., d)`` -> normalised ``(..., d)`` (in ``[-1, 1]`` inside the box)."""
        center, half = self._center_half_width()
        safe = np.where(half > 0, half, 1.0)
        return np.where(half > 0, (np.asarray(x, dtype=float) - center) / safe, 0.0)

    def from_unit(self, u: np.ndarray) -> np.ndarray:
        """Normalised ``(..., d)`` -> physical ``(..., d)``."""
        center, half = self._center_half_width()
        return center + np.asarray(u, dtype=float) * half

    def to_json(self) -> dict[str, Any]:
        return {"lows": list(self.lows), "highs": list(self.highs), "range": [-1.0, 1.0]}

    @staticmethod
    def from_json(data: dict[str, Any]) -> BoxNormalizer:
        return BoxNormalizer(tuple(map(float, data["lows"])), tuple(map(float, data["highs"])))


def joint_space(spec: SkillSpec) -> ParamSpace:
    """The GP input box in the order ``[control..., context...]``."""
    return ParamSpace(
        names=tuple(spec.control.names) + tuple(spec.context.names),
        lows=tuple(spec.control.lows) + tuple(spec.context.lows),
        highs=tuple(spec.control.highs) + tuple(spec.context.highs),
    )


def join_inputs(spec: SkillSpec, contexts: np.ndarray, controls: np.ndarray) -> np.ndarray:
    """Stack physical ``controls (n, dθ)`` and ``contexts (n, dα)`` into ``(n, dθ + dα)``.

    A single context of shape ``(dα,)`` is broadcast to every control.
    """
    controls = np.asarray(controls, dtype=float).reshape(-1, spec.control.dim)
    contexts = np.asarray(contexts, dtype=float)
    if contexts.ndim <= 1:
        contexts = np.broadcast_to(
            contexts.reshape(1, spec.context.dim), (len(controls), spec.context.dim)
        )
    contexts = contexts.reshape(len(contexts), spec.context.dim)
    if len(contexts) != len(controls):
        raise ValueError(f"{len(contexts)} contexts for {len(controls)} controls")
    return np.concatenate([controls, contexts], axis=1)


def split_inputs(spec: SkillSpec, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of :func:`join_inputs`: ``(n, d)`` -> ``(contexts (n, dα), controls (n, dθ))``."""
    x = np.asarray(x, dtype=float).reshape(-1, spec.control.dim + spec.context.dim)
    return x[:, spec.control.dim :], x[:, : spec.control.dim]
