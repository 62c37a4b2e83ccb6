"""Fitted scikit-learn baselines as plain arrays, and numpy predictors rebuilt from them.

Model directories are data, never code: a random forest or a multi-layer perceptron is saved
as its fitted numbers (tree nodes, layer weights) in an ``.npz`` read with
``allow_pickle=False``, and loaded into :class:`ForestArrays` / :class:`PerceptronArrays`,
which predict exactly like the scikit-learn estimators they were exported from (same
arithmetic in the same order; a test checks equality).

Array names in the ``.npz``:

* forest — ``tree_offsets (T + 1,)`` (node ranges of the ``T`` trees), per node
  ``children_left``, ``children_right``, ``feature`` (int64), ``threshold`` (float64) and
  ``value (nodes, n_values)``; classifiers add ``classes (C,)`` (bool);
* perceptron — ``coef_0 … coef_{L-1}`` ``(d_in, d_out)`` and ``intercept_0 …``, classifiers
  add ``classes``; the activations are named in ``model.json``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.special import expit

FOREST_KINDS = ("rf-c", "rf-r")
PERCEPTRON_KINDS = ("nn-c", "nn-r")
ACTIVATIONS = ("relu", "tanh", "logistic", "identity")
LEAF = -1


class ForestArrays:
    """A random forest as node arrays; ``predict``/``predict_proba`` like scikit-learn's."""

    def __init__(self, arrays: dict[str, np.ndarray], is_classifier: bool) -> None:
        self.offsets = arrays["tree_offsets"]
        self.left = arrays["children_left"]
        self.right = arrays["children_right"]
        self.feature = arrays["feature"]
        self.threshold = arrays["threshold"]
        self.value = arrays["value"]
        self.is_classifier = is_classifier
        self.classes_ = arrays["classes"] if is_classifier else None

    def _tree_values(self, x: np.ndarray, tree: int) -> np.ndarray:
        """Leaf values ``(n, n_values)`` of tree ``tree`` for inputs ``x (n, d)``."""
        start = int(self.offsets[tree])
        # scikit-learn compares float32 inputs with float64 thresholds.
        x32 = np.asarray(x, dtype=np.float32)
        rows = np.arange(len(x))
        node = np.full(len(x), start, dtype=np.int64)
        while True:
            inner = self.left[node] != LEAF
            if not inner.any():
                break
            at = node[inner]
            goes_left = x32[rows[inner], self.feature[at]] <= self.threshold[at]
            node[inner] = start + np.where(goes_left, self.left[at], self.right[at])
        return self.value[node]

    def predict_proba(self, x: np.ndarray) -> np.ndarray:
        """Class probabilities ``(n, C)``: the mean of every tree's normalised leaf counts."""
        total = np.zeros((len(x), len(self.classes_)), dtype=np.float64)
        for tree in range(len(self.offsets) - 1):
            proba = self._tree_values(x, tree).copy()
            normalizer = proba.sum(axis=1)[:, np.newaxis]
            normalizer[normalizer == 0.0] = 1.0
            proba /= normalizer
            total += proba
        total /= len(self.offsets) - 1
        return total

    def predict(self, x: np.ndarray) -> np.ndarray:
        """Regression ``(n,)``: the mean of every tree's leaf value."""
        total = np.zeros(len(x), dtype=np.float64)
        for tree in range(len(self.offsets) - 1):
            total += self._tree_values(x, tree)[:, 0]
        total /= len(self.offsets) - 1
        return total


class PerceptronArrays:
    """A multi-layer perceptron as weight arrays; predicts like scikit-learn's MLP."""

    def __init__(self, arrays: dict[str, np.ndarray], activation: str, out_activation: str,
                 is_classifier: bool) -> None:
        layers = sum(1 for name in arrays if name.startswith("coef_"))
        self.coefs = [arrays[f"coef_{i}"] for i in range(layers)]
        self.intercepts = [arrays[f"intercept_{i}"] for i in range(layers)]
        self.activation = activation
        self.out_activation = out_activation
        self.classes_ = arrays["classes"] if is_classifier else None

    def _forward(self, x: np.ndarray) -> np.ndarray:
        activation = np.asarray(x, dtype=np.float64)
        for i, (coef, intercept) in enumerate(zip(self.coefs, self.intercepts, strict=True)):
            activation = activation @ coef
            activation += intercept
            last = i == len(self.coefs) - 1
            activation = _activate(self.out_activation if last else self.activation, activation)
        return activation

    def predict_proba(self, x: np.ndarray) -> np.ndarray:
        """Binary class probabilities ``(n, 2)`` (the models learn ``score > 0``)."""
        p = self._forward(x).ravel()
        return np.vstack([1.0 - p, p]).T

    def predict(self, x: np.ndarray) -> np.ndarray:
        return self._forward(x).ravel()


def _activate(name: str, z: np.ndarray) -> np.ndarray:
    if name == "relu":
        return np.maximum(z, 0.0)
    if name == "tanh":
        return np.tanh(z)
    if name == "logistic":
        return expit(z)
    return z


def export_estimator(kind: str, estimator: Any) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Arrays (for the ``.npz``) and JSON settings of a fitted scikit-learn baseline."""
    arrays: dict[str, np.ndarray] = {}
    settings: dict[str, Any] = {}
    if kind.endswith("-c"):
        arrays["classes"] = np.asarray(estimator.classes_, dtype=bool)
    if kind in FOREST_KINDS:
        trees = [tree.tree_ for tree in estimator.estimators_]
        sizes = [tree.node_count for tree in trees]
        arrays["tree_offsets"] = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        arrays["children_left"] = np.concatenate([t.children_left for t in trees]).astype(np.int64)
        arrays["children_right"] = np.concatenate(
            [t.children_right for t in trees]).astype(np.int64)
        arrays["feature"] = np.concatenate([t.feature for t in trees]).astype(np.int64)
        arrays["threshold"] = np.concatenate([t.threshold for t in trees]).astype(np.float64)
        arrays["value"] = np.concatenate(
            [t.value[:, 0, :] for t in trees]).astype(np.float64)
    else:
        for i, (coef, intercept) in enumerate(
                zip(estimator.coefs_, estimator.intercepts_, strict=True)):
            arrays[f"coef_{i}"] = np.asarray(coef, dtype=np.float64)
            arrays[f"intercept_{i}"] = np.asarray(intercept, dtype=np.float64)
        settings = {"activation": estimator.activation,
                    "out_activation": estimator.out_activation_}
    return arrays, settings


def import_estimator(kind: str, arrays: dict[str, np.ndarray], settings: dict[str, Any],
                     n_features: int) -> ForestArrays | PerceptronArrays:
    """Rebuild a predictor from :func:`export_estimator`'s output; bad data raises ValueError.

    Every array's dtype, shape and range is checked, so a crafted file can neither index out
    of bounds nor loop forever (children must point forward inside their tree).
    """
    is_classifier = kind.endswith("-c")
    if is_classifier:
        classes = _array(arrays, "classes", 1)
        if classes.dtype != bool or classes.tolist() != [False, True]:
            raise ValueError("'classes' must be [false, true]")
    if kind in FOREST_KINDS:
        offsets = _integers(arrays, "tree_offsets", 1)
        if len(offsets) < 2 or offsets[0] != 0 or np.any(np.diff(offsets) < 1):
            raise ValueError("'tree_offsets' must start at 0 and increase")
        nodes = int(offsets[-1])
        tree_start = np.repeat(offsets[:-1], np.diff(offsets))
        tree_end = np.repeat(offsets[1:], np.diff(offsets))
        own = np.arange(nodes)
        for side in ("children_left", "children_right"):
            child = _integers(arrays, side, 1, nodes)
            inner = child != LEAF
            absolute = tree_start + child
            if np.any(inner & ((absolute <= own) | (absolute >= tree_end))):
                raise ValueError(f"{side!r} must point forward inside its own tree")
        left, right = arrays["children_left"], arrays["children_right"]
        if np.any((left == LEAF) != (right == LEAF)):
            raise ValueError("a node has one child only")
        feature = _integers(arrays, "feature", 1, nodes)
        if np.any((left != LEAF) & ((feature < 0) | (feature >= n_features))):
            raise ValueError(f"'feature' must index one of the {n_features} inputs")
        _finite(arrays, "threshold", 1, nodes, allow_nan_leaves=left == LEAF)
        width = 2 if is_classifier else 1
        value = _finite(arrays, "value", 2, nodes)
        if value.shape[1] != width:
            raise ValueError(f"'value' must have {width} column(s), not {value.shape[1]}")
        return ForestArrays(arrays, is_classifier)
    activation = settings.get("activation")
    out_activation = settings.get("out_activation")
    if activation not in ACTIVATIONS or out_activation not in ACTIVATIONS:
        raise ValueError(f"activations must be among {', '.join(ACTIVATIONS)}")
    layers = sum(1 for name in arrays if name.startswith("coef_"))
    if layers < 1:
        raise ValueError("no 'coef_0' array")
    width = n_features
    for i in range(layers):
        coef = _finite(arrays, f"coef_{i}", 2)
        intercept = _finite(arrays, f"intercept_{i}", 1)
        if coef.shape[0] != width or intercept.shape != (coef.shape[1],):
            raise ValueError(f"layer {i} has shape {coef.shape} + {intercept.shape}, "
                             f"expected ({width}, k) + (k,)")
        width = coef.shape[1]
    if width != 1:
        raise ValueError(f"the last layer must have one output, not {width}")
    return PerceptronArrays(arrays, activation, out_activation, is_classifier)


def _array(arrays: dict[str, np.ndarray], name: str, ndim: int,
           length: int | None = None) -> np.ndarray:
    if name not in arrays:
        raise ValueError(f"missing array {name!r}")
    array = arrays[name]
    if array.ndim != ndim or (length is not None and len(array) != length):
        expected = f"{ndim}-d" + (f" of length {length}" if length is not None else "")
        raise ValueError(f"array {name!r} has shape {array.shape}, expected {expected}")
    return array


def _integers(arrays: dict[str, np.ndarray], name: str, ndim: int,
              length: int | None = None) -> np.ndarray:
    array = _array(arrays, name, ndim, length)
    if not np.issubdtype(array.dtype, np.integer):
        raise ValueError(f"array {name!r} must hold integers, not {array.dtype}")
    return array


def _finite(arrays: dict[str, np.ndarray], name: str, ndim: int, length: int | None = None,
            allow_nan_leaves: np.ndarray | None = None) -> np.ndarray:
    array = _array(arrays, name, ndim, length)
    if not np.issubdtype(array.dtype, np.floating):
        raise ValueError(f"array {name!r} must hold floats, not {array.dtype}")
    finite = np.isfinite(array)
    if allow_nan_leaves is not None:
        finite = finite | allow_nan_leaves  # leaves carry no threshold
    if not finite.all():
        raise ValueError(f"array {name!r} holds NaN or infinite values")
    return array
