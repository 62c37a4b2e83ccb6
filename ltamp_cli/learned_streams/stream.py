"""A learned stream: planner inputs -> context -> sampled controls -> stream outputs.

A problem YAML configures each learned stream under ``world.learned_streams.<stream name>``::

    learned_streams:
      sample-good-control:
        model: model            # model directory (relative paths: see from_mapping's base)
        sampler: diverse-lk     # rejection | adaptive | diverse | diverse-lk
        lambda: 0.95            # relaxed-β λ (optional), or beta: 1.5 (optional)
        kernel_file: null       # diverse-lk only; default: the user cache (see kernel_path)
        extrapolate: false      # true: also sample contexts outside the model's trained range

A context outside the range the model was trained on (the skill's context box) gets no
samples unless ``extrapolate: true`` (one warning per stream; :func:`make_sampler` refuses
such a context the same way, as ``ltamp sample --context`` does): away from its data a GP's
mean reverts to its prior, so a set "learned" there is a guess.

The model is loaded once per :class:`LearnedStream` (pass a shared :class:`ModelCache` to load
a directory once for several streams) and never retrained. Each call of the stream (one input
tuple) gets its own sampler; every output is remembered with the control that made it so that
:meth:`LearnedStream.on_unusable` can report that control to its sampler (``diverse-lk``
learns its diversity kernel from it and the kernel is saved to ``kernel_file``).
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import os
from collections.abc import Callable, Hashable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.backends.protocol import SkillSpec
from ltamp_cli.errors import InputError
from ltamp_cli.learning.confidence import LAMBDA_RANGE
from ltamp_cli.learning.model import LevelSetModel
from ltamp_cli.learning.model_dir import load_model
from ltamp_cli.planner.streams import Binding, StreamInfo
from ltamp_cli.sampling.base import SetSampler
from ltamp_cli.sampling.factory import SAMPLER_NAMES, make_sampler, outside_trained_range
from ltamp_cli.sampling.kernel_learning import DiversityKernel, load_kernel, save_kernel
from ltamp_cli.sampling.superlevel import DEFAULT_LAMBDA, PhysicalValidity

KERNEL_FILE = "diversity_kernel.json"
_FIELDS = ("model", "sampler", "lambda", "beta", "kernel_file", "extrapolate")
LOGGER = logging.getLogger("ltamp")


def model_identity(model_dir: Path) -> str:
    """A short id of a model: its recorded weights digest, else its resolved path's digest."""
    try:
        digest = json.loads((model_dir / "model.json").read_text()).get("weights_sha256")
    except (OSError, ValueError, AttributeError):
        digest = None
    if not isinstance(digest, str) or not digest:
        digest = hashlib.sha256(str(model_dir.resolve()).encode()).hexdigest()
    return digest[:16]


@dataclass(frozen=True)
class LearnedStreamConfig:
    """Which model and sampler a learned stream uses. Paths are absolute or cwd-relative."""

    model_dir: Path
    sampler: str = "adaptive"
    lam: float = DEFAULT_LAMBDA
    beta: float | None = None
    kernel_file: Path | None = None
    extrapolate: bool = False

    def __post_init__(self) -> None:
        if self.sampler not in SAMPLER_NAMES:
            raise InputError(
                f"unknown sampler {self.sampler!r}: expected one of {', '.join(SAMPLER_NAMES)}"
            )

    @property
    def kernel_path(self) -> Path:
        """Where ``diverse-lk`` keeps its learned kernel.

        Default: ``$XDG_CACHE_HOME/ltamp/diversity-kernels/<model id>/diversity_kernel.json``,
        shared by every task that uses the same model (the paper transfers kernels across
        tasks) but never written into the model directory, which may be shipped read-only
        and whose kernel would otherwise carry one run's learning into the next test.
        """
        if self.kernel_file is not None:
            return self.kernel_file
        base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        kernels = Path(base) / "ltamp" / "diversity-kernels"
        return kernels / model_identity(self.model_dir) / KERNEL_FILE

    @staticmethod
    def from_mapping(data: Any, base: Path, where: str) -> LearnedStreamConfig:
        """Parse one ``learned_streams`` entry; relative paths are resolved against ``base``.

        ``where`` names the entry in error messages (e.g. ``world.learned_streams.s``).
        """
        if not isinstance(data, Mapping):
            raise InputError(f"{where}: expected a mapping with 'model' and 'sampler'")
        unknown = sorted(set(map(str, data)) - set(_FIELDS))
        if unknown:
            raise InputError(f"{where}: unknown field {unknown[0]!r}: expected one of "
                             f"{', '.join(_FIELDS)}")
        if not isinstance(data.get("model"), str):
            raise InputError(f"{where}.model: expected the path of a model directory")

        def number(key: str) -> float | None:
            value = data.get(key)
            if value is None:
                return None
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise InputError(f"{where}.{key}: expected a number, got {value!r}")
            return float(value)

        kernel_file = data.get("kernel_file")
        if kernel_file is not None and not isinstance(kernel_file, str):
            raise InputError(f"{where}.kernel_file: expected a path")
        extrapolate = data.get("extrapolate", False)
        if not isinstance(extrapolate, bool):
            raise InputError(f"{where}.extrapolate: expected true or false, got {extrapolate!r}")
        lam = number("lambda")
        beta = number("beta")
        # the same limits as `ltamp sample --lambda/--beta` (ltamp_cli/cli/options.py)
        if lam is not None and not LAMBDA_RANGE[0] <= lam <= LAMBDA_RANGE[1]:
            raise InputError(f"{where}.lambda: expected a value in [{LAMBDA_RANGE[0]}, "
                             f"{LAMBDA_RANGE[1]}], got {lam}")
        if beta is not None and not math.isfinite(beta):
            raise InputError(f"{where}.beta: expected a finite number, got {beta}")
        try:
            return LearnedStreamConfig(
                model_dir=(base / data["model"]).resolve(),
                sampler=str(data.get("sampler", "adaptive")),
                lam=DEFAULT_LAMBDA if lam is None else lam,
                beta=beta,
                kernel_file=None if kernel_file is None else (base / kernel_file).resolve(),
                extrapolate=extrapolate,
            )
        except InputError as error:
            raise InputError(f"{where}.sampler: {error.message}") from None


class ModelCache:
    """Loads each model directory once (per cache, not per process)."""

    def __init__(self) -> None:
        self._models: dict[Path, LevelSetModel] = {}

    def get(self, model_dir: Path) -> LevelSetModel:
        key = Path(model_dir).resolve()
        if key not in self._models:
            model = load_model(key).model
            if not isinstance(model, LevelSetModel):
                raise InputError(f"{key}: learned streams need a GP model, this one is "
                                 f"{model.kind!r}")
            self._models[key] = model
        return self._models[key]


def _freeze(value: Any) -> Hashable:
    """A hashable stand-in for a stream value (arrays and sequences become tuples)."""
    if isinstance(value, np.ndarray):
        return ("array", tuple(np.asarray(value, dtype=float).ravel().tolist()), value.shape)
    if isinstance(value, list | tuple):
        return tuple(_freeze(v) for v in value)
    if isinstance(value, dict):
        return tuple(sorted((str(k), _freeze(v)) for k, v in value.items()))
    if isinstance(value, np.generic):
        return value.item()
    return value


def _has_valid_member(sampler: SetSampler) -> bool:
    """False when the set has a hard test and neither θ* nor any of the uniform controls
    scored to build it passed: the valid part of the set is then too small to search for
    (the samplers would spend all their proposal rounds on it)."""
    superlevel = sampler.superlevel
    if superlevel.is_valid is None:
        return True
    if superlevel.seed_members is not None and len(superlevel.seed_members):
        return True
    star = superlevel.theta_star
    return star is not None and bool(superlevel.contains(star.reshape(1, -1))[0])


def _check_model_shape(spec: SkillSpec, model_dir: Path, context_names: Sequence[str] | None,
                       control_names: Sequence[str] | None) -> None:
    """The model must be of the skill the bindings map inputs to and controls from.

    A model of another skill (``world.learned_streams`` naming the push model for the scoop
    stream) would otherwise be queried with meaningless contexts and answer "no samples"
    (a wrong "infeasible"), or fail deep in numpy.
    """
    expected = (None if context_names is None else tuple(context_names),
                None if control_names is None else tuple(control_names))
    found = (spec.context.names, spec.control.names)
    if all(want is None or want == got for want, got in zip(expected, found, strict=True)):
        return

    def names(values: Sequence[str] | None) -> str:
        return "?" if values is None else f"({', '.join(values)})"
    raise InputError(
        f"learned stream over {model_dir}: this model is skill {spec.name!r} with context "
        f"{names(found[0])} and control {names(found[1])}, but the stream needs context "
        f"{names(expected[0])} and control {names(expected[1])}: is world.learned_streams "
        "pointing at the right model?")


def _check_model_bounds(model: SkillSpec, skill: SkillSpec, model_dir: Path) -> None:
    """The model must have been trained on ``skill``'s boxes: a control box that has since
    changed would hand the stream controls the skill no longer accepts (or never explore
    the new part), a context box a range the stream's contexts do not have."""
    for part, trained, declared in (("context", model.context, skill.context),
                                    ("control", model.control, skill.control)):
        for name, low, high, want_low, want_high in zip(
                trained.names, trained.lows, trained.highs, declared.lows, declared.highs,
                strict=True):
            tolerance = 1e-9 * max(1.0, abs(want_high - want_low))
            if abs(low - want_low) > tolerance or abs(high - want_high) > tolerance:
                raise InputError(
                    f"learned stream over {model_dir}: the model was trained on {part} "
                    f"{name} in [{low:g}, {high:g}], but skill {skill.name!r} declares "
                    f"[{want_low:g}, {want_high:g}]: retrain it (ltamp train) or point "
                    "world.learned_streams at a model of the current skill")


class LearnedStream:
    """A planner stream drawing controls of a learned skill.

    ``to_context(*inputs) -> (dα,)`` physical context; ``to_outputs(control, *inputs)`` ->
    output tuple (or ``None`` to skip a control the stream cannot use);
    ``is_valid(context, controls)`` an optional hard test applied inside the sampler;
    ``validity_for(*inputs)`` an optional hard test *of one input tuple* (e.g. the tilt of a
    pour must not graze the target cup *at its pose*, which the context does not hold):
    it returns ``(context (dα,), controls (n, dθ)) -> (n,) bool`` (or ``None``: no test for
    these inputs). Both are part of the membership of the sampler's super-level set, so θ*,
    β and the proposals are built over valid controls only, not filtered afterwards. A
    call whose set shows no valid member (θ* invalid and none of the sampler's first uniform
    proposals valid) ends at once.

    Pass the skill's :class:`SkillSpec` as ``skill`` (or at least its ``context_names`` and
    ``control_names``) so that a model of another skill, or one trained on other bounds, is
    refused in one line when the stream is built. Without them only the sizes can be checked,
    on the stream's first call: a context of the wrong size, or a ``to_outputs`` that fails
    on the model's controls (e.g. indexes a value the model does not have), is one
    :class:`InputError` line naming the model's parameters.

    ``rng_for(*inputs)``, if given, returns the generator each input tuple's sampler draws
    from (e.g. :class:`ltamp_cli.planner.keyed_random.KeyedRandom` keyed by the inputs), so
    one instance's controls do not depend on the draws of the others; otherwise every
    sampler draws from ``rng``.
    """

    def __init__(
        self,
        config: LearnedStreamConfig,
        to_context: Callable[..., np.ndarray],
        to_outputs: Callable[..., tuple[Any, ...] | None],
        rng: np.random.Generator,
        is_valid: PhysicalValidity | None = None,
        models: ModelCache | None = None,
        validity_for: Callable[..., PhysicalValidity | None] | None = None,
        *,
        context_names: Sequence[str] | None = None,
        control_names: Sequence[str] | None = None,
        skill: SkillSpec | None = None,
        rng_for: Callable[..., np.random.Generator] | None = None,
    ) -> None:
        self.config = config
        self.to_context = to_context
        self.to_outputs = to_outputs
        self.rng = rng
        self.rng_for = rng_for
        self.is_valid = is_valid
        self.validity_for = validity_for
        self.model = (models or ModelCache()).get(config.model_dir)
        if skill is not None:
            if not isinstance(skill, SkillSpec):
                raise InputError(f"LearnedStream(skill=...) expects the skill's SkillSpec, "
                                 f"got {type(skill).__name__}")
            for given, own, part in ((context_names, skill.context.names, "context"),
                                     (control_names, skill.control.names, "control")):
                if given is not None and tuple(given) != own:
                    raise InputError(f"LearnedStream: {part}_names {tuple(given)} differ from "
                                     f"skill {skill.name!r}'s {own}")
            context_names, control_names = skill.context.names, skill.control.names
        _check_model_shape(self.model.spec, config.model_dir, context_names, control_names)
        if skill is not None:
            _check_model_bounds(self.model.spec, skill, config.model_dir)
        self.kernel: DiversityKernel | None = None
        if config.sampler == "diverse-lk":
            self.kernel = load_kernel(config.kernel_path, self.model.spec)
        self._issued: dict[Hashable, tuple[SetSampler, np.ndarray]] = {}
        self.n_samples = 0
        self.n_unusable = 0
        self.n_outside = 0  # calls whose context lay outside the trained range
        self._kernel_unsaved = False  # a save of the diverse-lk kernel failed (warned once)

    @property
    def spec(self) -> SkillSpec:
        return self.model.spec

    def sampler_for(self, *inputs: Any) -> SetSampler | None:
        """A fresh sampler for the context of ``inputs``, or ``None`` when that context lies
        outside the model's trained range and the stream may not extrapolate."""
        context = np.asarray(self.to_context(*inputs), dtype=float)
        if context.size != self.model.spec.context.dim:
            spec = self.model.spec
            raise InputError(
                f"learned stream over {self.config.model_dir}: the bindings give a context of "
                f"{context.size} value(s), but this {spec.name!r} model's context has "
                f"{spec.context.dim} ({', '.join(spec.context.names) or 'none'}): is "
                "world.learned_streams pointing at the right model?")
        context = context.reshape(self.model.spec.context.dim)
        if not np.all(np.isfinite(context)):
            # a NaN/inf value (e.g. an object `1e400` the bindings read with float()) lies in
            # no range: "no samples" would turn it into a wrong "infeasible"
            spec = self.model.spec
            values = ", ".join(f"{n}={v:g}" for n, v in zip(spec.context.names, context,
                                                            strict=True))
            raise InputError(
                f"learned stream over {self.config.model_dir}: the bindings give the "
                f"non-finite context ({values}) for the inputs {inputs!r:.80}: check the "
                "problem's object values")
        if not self.config.extrapolate:
            outside = outside_trained_range(self.model.spec, context)
            if outside:
                if not self.n_outside:
                    LOGGER.warning("learned stream of %s (%s): context outside the trained "
                                   "range, no samples (%s); set extrapolate: true to sample "
                                   "there anyway", self.model.spec.name,
                                   self.config.model_dir, outside)
                self.n_outside += 1
                return None
        return make_sampler(
            self.config.sampler, self.model, context,
            self.rng if self.rng_for is None else self.rng_for(*inputs), beta=self.config.beta,
            is_valid=self.validity(*inputs), lam=self.config.lam, kernel=self.kernel,
            extrapolate=True,
        )

    def validity(self, *inputs: Any) -> PhysicalValidity | None:
        """The hard test of ``inputs``: ``is_valid`` and ``validity_for(*inputs)`` together."""
        tests = [self.is_valid]
        if self.validity_for is not None:
            tests.append(self.validity_for(*inputs))
        present = [t for t in tests if t is not None]
        if len(present) <= 1:
            return present[0] if present else None
        first, second = present

        def both(context: np.ndarray, controls: np.ndarray) -> np.ndarray:
            ok = np.asarray(first(context, controls), dtype=bool).copy()
            if ok.any():  # the second (often dearer) test only where the first passed
                ok[ok] = np.asarray(second(context, controls[ok]), dtype=bool)
            return ok

        return both

    def __call__(self, *inputs: Any) -> Iterator[tuple[Any, ...]]:
        """The planner's generator for one input tuple: one output tuple per ``next()``."""
        sampler: SetSampler | None = None
        frozen_inputs = _freeze(inputs)
        while True:
            if sampler is None:
                sampler = self.sampler_for(*inputs)
                if sampler is None or not _has_valid_member(sampler):
                    return
            control = next(sampler, None)
            if control is None:
                return
            outputs = self._outputs(control, inputs)
            if outputs is None:
                continue
            outputs = tuple(outputs)
            self.n_samples += 1
            self._issued[(frozen_inputs, _freeze(outputs))] = (sampler, control)
            yield outputs

    def _outputs(self, control: np.ndarray, inputs: tuple[Any, ...]
                 ) -> tuple[Any, ...] | None:
        """``to_outputs(control, *inputs)``; an indexing or shape error there means the
        bindings expect other controls than this model's (a model of another skill, when
        the stream knows no parameter names): one line naming both, not a traceback."""
        try:
            return self.to_outputs(control, *inputs)
        except (IndexError, ValueError, TypeError) as error:
            spec = self.model.spec
            raise InputError(
                f"learned stream over {self.config.model_dir}: its bindings could not use a "
                f"control of this {spec.name!r} model ({spec.control.dim} value(s): "
                f"{', '.join(spec.control.names)}): {type(error).__name__}: {error}: is "
                "world.learned_streams pointing at the right model?") from None

    def on_unusable(self, inputs: tuple[Any, ...], outputs: tuple[Any, ...]) -> None:
        """Planner feedback: ``outputs`` (made for ``inputs``) failed downstream."""
        entry = self._issued.get((_freeze(tuple(inputs)), _freeze(tuple(outputs))))
        if entry is None:
            return
        self.n_unusable += 1
        sampler, control = entry
        if sampler.report_unusable(control) is not None and self.kernel is not None:
            try:
                save_kernel(self.kernel, self.config.kernel_path, self.model.spec)
            except OSError as error:  # a read-only or full cache: learn for this run only
                if not self._kernel_unsaved:
                    LOGGER.warning("learned stream of %s: cannot save its diversity kernel to "
                                   "%s (%s); it is learned for this run only",
                                   self.model.spec.name, self.config.kernel_path,
                                   error.strerror or error)
                self._kernel_unsaved = True

    def binding(self, info: StreamInfo | None = None) -> Binding:
        """The planner :class:`Binding`, with :meth:`on_unusable` wired as its feedback."""
        return Binding(self, info or StreamInfo(), on_unusable=self.on_unusable)


def learned_stream_configs(world: Mapping[str, Any], base: Path
                           ) -> dict[str, LearnedStreamConfig]:
    """Every ``world.learned_streams`` entry, parsed (relative paths against ``base``)."""
    entries = world.get("learned_streams", {}) or {}
    if not isinstance(entries, Mapping):
        raise InputError("world.learned_streams: expected a mapping of stream name to settings")
    return {
        str(name): LearnedStreamConfig.from_mapping(entry, base, f"world.learned_streams.{name}")
        for name, entry in entries.items()
    }
