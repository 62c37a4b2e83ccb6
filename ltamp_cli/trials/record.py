"""Trial records and append-only JSONL datasets.

One trial per line. Lines are appended with a single ``write`` on an ``O_APPEND`` file
descriptor followed by ``fsync``, so concurrent writers never interleave and a crash can at
worst leave one partial last line, which :meth:`TrialDataset.read` ignores and the next
:meth:`TrialDataset.append` removes first. Nothing ever rewrites earlier lines.
"""

from __future__ import annotations

import contextlib
import errno
import json
import math
import os
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ltamp_cli.errors import InputError, location_in

if TYPE_CHECKING:
    from ltamp_cli.backends.protocol import SkillSpec


@dataclass(frozen=True)
class TrialRecord:
    """One executed (or imported) trial of a skill.

    ``context``/``control`` are in physical units, in the order of the skill's
    :class:`~ltamp_cli.backends.protocol.ParamSpace` names. ``index`` identifies the trial
    within the job that produced it (collection resumes by skipping done indices). ``info``
    holds the skill's measurements; an invalid trial says why in ``info["reason"]`` (e.g.
    ``"colliding start"``, ``"physics diverged: ..."``, ``"trial raised ..."``).
    ``outcome`` is the trial's declared outcome (``SkillSpec.outcome``, physical units, in
    the order of its names) or ``None``; the JSON line has an ``"outcome"`` field only when
    it is not ``None``, so records of skills without one are written as before.
    ``setup`` names the versioned trial setup that produced the record when the backend has
    one (:func:`~ltamp_cli.backends.protocol.trial_setup`; the Panda's: ``"panda-r3"``) and
    is written only when not ``None``: the labels of two setups differ, so a file or a run
    never mixes them (``ltamp collect``/``train`` refuse, as for two backends).
    ``physics`` is the backend's physics tag when the trial ran (e.g. ``pybullet@v1.1``,
    :mod:`ltamp_cli.trials.physics`) or ``None`` (an unversioned backend, an imported trial,
    or a record written before the field; written only when set).
    """

    skill: str
    context: tuple[float, ...]
    control: tuple[float, ...]
    score: float
    valid: bool
    seed: int
    backend: str
    wall_time_s: float = 0.0
    index: int = -1
    info: Mapping[str, Any] = field(default_factory=dict)
    outcome: tuple[float, ...] | None = None
    setup: str | None = None
    physics: str | None = None

    def to_json(self) -> str:
        record = asdict(self)
        record["context"] = [float(v) for v in self.context]
        record["control"] = [float(v) for v in self.control]
        record["score"] = _finite_or_none(self.score)
        record["info"] = dict(self.info)
        if self.outcome is None:
            del record["outcome"]
        else:
            record["outcome"] = [float(v) for v in self.outcome]
        if self.setup is None:
            del record["setup"]
        if self.physics is None:
            del record["physics"]
        return json.dumps(record, sort_keys=True, allow_nan=False)

    @staticmethod
    def from_dict(data: Mapping[str, Any]) -> TrialRecord:
        """A record from its JSON object. Fields must have their own JSON types (``"valid":
        "false"`` is no boolean, ``"context": "5"`` no list): ``ValueError``/``TypeError``
        name the field. ``context`` and ``control`` must be finite; ``score`` is a finite
        number or ``null``/``NaN`` (an invalid trial); ``outcome``, optional, a list of
        finite numbers or ``null``; ``setup`` and ``physics``, optional, non-empty strings or
        ``null`` (an empty name would read as "no recorded setup/physics" in messages while
        comparing unequal to it)."""
        if not isinstance(data, Mapping):
            raise TypeError(f"expected a JSON object, got {type(data).__name__}")
        score = data["score"]
        return TrialRecord(
            skill=_text(data["skill"], "skill"),
            context=_finite_values(data["context"], "context"),
            control=_finite_values(data["control"], "control"),
            score=float("nan") if score is None else _number(score, "score", nan_ok=True),
            valid=_boolean(data["valid"], "valid"),
            seed=_integer(data["seed"], "seed"),
            backend=_text(data["backend"], "backend"),
            wall_time_s=_number(data.get("wall_time_s", 0.0), "wall_time_s", nan_ok=True),
            index=_integer(data.get("index", -1), "index"),
            info=_mapping(data.get("info", {}), "info"),
            outcome=(None if data.get("outcome") is None
                     else _finite_values(data["outcome"], "outcome")),
            setup=None if data.get("setup") is None else _tag(data["setup"], "setup"),
            physics=None if data.get("physics") is None else _tag(data["physics"], "physics"),
        )


def setup_words(setup: str | None) -> str:
    """``setup`` for a message: ``setup 'panda-r3'`` or ``no recorded setup``."""
    return "no recorded setup" if setup is None else f"setup {setup!r}"


def _text(value: Any, name: str) -> str:
    if not isinstance(value, str):
        raise TypeError(f"field {name!r} must be a string, got {value!r:.40}")
    return value


def _tag(value: Any, name: str) -> str:
    if not (isinstance(value, str) and value.strip()):
        raise TypeError(f"field {name!r} must be a non-empty string or null, got {value!r:.40}")
    return value


def _boolean(value: Any, name: str) -> bool:
    if not isinstance(value, bool):
        raise TypeError(f"field {name!r} must be true or false, got {value!r:.40}")
    return value


def _integer(value: Any, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise TypeError(f"field {name!r} must be an integer, got {value!r:.40}")
    return value


def _number(value: Any, name: str, nan_ok: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise TypeError(f"field {name!r} must be a number, got {value!r:.40}")
    number = float(value)
    if math.isinf(number) or (math.isnan(number) and not nan_ok):
        raise ValueError(f"field {name!r} must be finite, got {value!r:.40}")
    return number


def _finite_values(value: Any, name: str) -> tuple[float, ...]:
    if not isinstance(value, list | tuple):
        raise TypeError(f"field {name!r} must be a list of numbers, got {value!r:.40}")
    return tuple(_number(item, name) for item in value)


def _mapping(value: Any, name: str) -> dict[str, Any]:
    if not isinstance(value, Mapping):
        raise TypeError(f"field {name!r} must be an object, got {value!r:.40}")
    return dict(value)


def _finite_or_none(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


_REQUIRED_FIELDS = ("skill", "context", "control", "score", "valid", "seed", "backend")


class TrialDataset:
    """An append-only JSONL file of :class:`TrialRecord` lines."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)

    def exists(self) -> bool:
        return self.path.exists()

    def read(self) -> list[TrialRecord]:
        """All complete records; a torn last line (crash while writing) is skipped."""
        return list(self.iter_records())

    def iter_records(self) -> Iterator[TrialRecord]:
        for _line, record in self.iter_numbered():
            yield record

    def iter_numbered(self) -> Iterator[tuple[int, TrialRecord]]:
        """``(line, record)`` for every complete record, ``line`` 1-based in the file (blank
        lines count), for messages that point at a record."""
        if not self.path.exists():
            return
        with self.path.open("rb") as handle:
            data = handle.read()
        if data.startswith(b"\x1f\x8b"):  # e.g. a pool archive (.jsonl.gz) given as is
            raise InputError("a gzip-compressed file, not JSON lines: decompress it first "
                             "(gunzip -k FILE)", location_in(self.path, 1, 1))
        lines = data.split(b"\n")
        # After the final newline split() yields b"". Any other last piece was torn by a
        # crash while writing, unless it is one whole record (a file written by another
        # tool, or saved by an editor, without a final newline).
        complete, tail = lines[:-1], lines[-1]
        if whole_record(tail) is not None:
            complete.append(tail)
        for number, raw in enumerate(complete, start=1):
            if not raw.strip():
                continue
            try:
                data = json.loads(raw)
                missing = [name for name in _REQUIRED_FIELDS if name not in data]
                if missing:
                    raise KeyError(", ".join(missing))
                record = TrialRecord.from_dict(data)
            except (ValueError, KeyError, TypeError, RecursionError) as error:
                raise InputError(
                    f"not a trial record ({type(error).__name__}: {error}); expected one JSON "
                    f"object per line with fields {', '.join(_REQUIRED_FIELDS)}",
                    location_in(self.path, number, 1),
                ) from None
            yield number, record

    def append(self, records: TrialRecord | Iterable[TrialRecord]) -> None:
        """Append records durably; each call is one atomic ``write``."""
        if isinstance(records, TrialRecord):
            records = [records]
        payload = "".join(record.to_json() + "\n" for record in records).encode()
        if not payload:
            return
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._drop_torn_tail()
        fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            size = os.fstat(fd).st_size  # one writer holds the file's lock: nobody else appends
            try:
                written = os.write(fd, payload)
                if written != len(payload):  # a full disk or a file size limit
                    raise OSError(errno.ENOSPC, f"only {written} of {len(payload)} bytes written "
                                  "(disk full or a file size limit)")
                os.fsync(fd)
            except OSError as error:
                # Nothing half-written: cut what this write added (shrinking needs no space).
                with contextlib.suppress(OSError):
                    os.ftruncate(fd, size)
                raise InputError(
                    f"{self.path}: could not append {len(payload.splitlines())} trial "
                    f"record(s): {error.strerror or error}; the file is unchanged (free some "
                    "space and run again to resume)") from None
        finally:
            os.close(fd)

    def _drop_torn_tail(self) -> None:
        if not self.path.exists():
            return
        with self.path.open("rb+") as handle:
            handle.seek(0, os.SEEK_END)
            size = handle.tell()
            if size == 0:
                return
            handle.seek(size - 1)
            if handle.read(1) == b"\n":
                return
            data = handle.seek(0) or handle.read()
            end = data.rfind(b"\n") + 1
            if whole_record(data[end:]) is not None:
                handle.seek(0, os.SEEK_END)
                handle.write(b"\n")  # a whole record: end it, do not cut it
            else:
                handle.truncate(end)
            handle.flush()
            os.fsync(handle.fileno())

    def done_indices(self) -> set[int]:
        return {record.index for record in self.iter_records() if record.index >= 0}


def whole_record(raw: bytes) -> TrialRecord | None:
    """The record a line holds if it is one whole, valid trial record, else ``None``."""
    if not raw.strip():
        return None
    try:
        data = json.loads(raw)
        if not isinstance(data, dict) or any(name not in data for name in _REQUIRED_FIELDS):
            return None
        return TrialRecord.from_dict(data)
    except (ValueError, KeyError, TypeError, RecursionError):
        return None


def without_duplicates(records: Sequence[TrialRecord]) -> tuple[list[TrialRecord], int]:
    """``records`` keeping the first of each ``(skill, backend, seed, index)`` (index ≥ 0)
    and how many repeats were dropped (two writers once shared the file)."""
    seen: set[tuple[str, str, int, int]] = set()
    kept: list[TrialRecord] = []
    for record in records:
        key = (record.skill, record.backend, record.seed, record.index)
        if record.index >= 0 and key in seen:
            continue
        seen.add(key)
        kept.append(record)
    return kept, len(records) - len(kept)


# Scores beyond this overflow the GP's squares (1e300² is inf): such a record is refused.
MAX_SCORE_MAGNITUDE = 1e100


def check_against_spec(records: Sequence[TrialRecord], spec: SkillSpec) -> None:
    """Raise ``ValueError`` naming the first record of ``spec``'s skill whose context or
    control has the wrong length or lies far outside the skill's box (more than one box
    width beyond a bound), whose outcome has another length than the skill declares, lies
    far outside its range or does not give the record's score through the skill's declared
    score function (valid records), or whose score's magnitude exceeds
    :data:`MAX_SCORE_MAGNITUDE`:
    such values make the GP's arithmetic overflow (NaN everywhere). Records of other skills
    are not checked."""
    for record in records:
        if record.skill != spec.name:
            continue
        where = f"trial record (seed {record.seed}, index {record.index})"
        for part, values, space in (("context", record.context, spec.context),
                                    ("control", record.control, spec.control)):
            if len(values) != len(space.names):
                raise ValueError(f"{where}: {part} has {len(values)} value(s), skill "
                                 f"{spec.name!r} has {len(space.names)} ({', '.join(space.names)})")
            for name, value, low, high in zip(space.names, values, space.lows, space.highs,
                                              strict=True):
                width = max(high - low, 1e-9)
                if not low - width <= value <= high + width:
                    raise ValueError(f"{where}: {part} {name}={value:g} lies far outside the "
                                     f"skill's bounds [{low:g}, {high:g}]")
        if (record.outcome is not None and spec.outcome is not None
                and len(record.outcome) != spec.outcome.space.dim):
            raise ValueError(f"{where}: outcome has {len(record.outcome)} value(s), skill "
                             f"{spec.name!r} declares {spec.outcome.space.dim}")
        if record.valid and record.outcome is not None and spec.outcome is not None:
            # as a live trial's: within range, and giving the record's score through the
            # declared function (else the GP learns the score and contradicting relabels)
            from ltamp_cli.backends.sanity import checked_outcome

            try:
                checked_outcome(spec, np.asarray(record.context, dtype=float),
                                np.asarray(record.control, dtype=float), record.score,
                                record.outcome)
            except ValueError as error:
                raise ValueError(f"{where}: {error}") from None
        if math.isfinite(record.score) and abs(record.score) > MAX_SCORE_MAGNITUDE:
            raise ValueError(f"{where}: score {record.score:g} is beyond ±{MAX_SCORE_MAGNITUDE:g}")


def training_score(record: TrialRecord, invalid_score: float = -1.0) -> float:
    """The score every learner, evaluator and pool reader takes from ``record``: its own
    score for a valid trial with a finite one; ``invalid_score`` (the skill's, ≤ 0) for a
    non-finite score, and for an *invalid* trial whose score claims a success (> 0).

    An invalid trial never ran to its end (colliding start, diverged physics, a raising
    plugin), so it is never a success whatever its score says. ltamp writes such trials with
    the skill's invalid score (``backends.sanity``), and ``import``/``tell`` refuse one that
    claims success, but other tools write JSONL files too; they are read as they are (nothing
    in the file is changed or lost) and labelled here. An invalid trial's score ≤ 0 is kept,
    as a live one's is."""
    if not math.isfinite(record.score) or (not record.valid and record.score > 0):
        return float(invalid_score)
    return float(record.score)


def is_success(record: TrialRecord) -> bool:
    """Whether ``record`` counts as a success: a valid trial with a finite score > 0."""
    return training_score(record) > 0


def records_to_arrays(
    records: Sequence[TrialRecord], invalid_score: float = -1.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Stack records into ``(contexts (n, dc), controls (n, dθ), scores (n,), valid (n,))``;
    the scores are :func:`training_score`'s (the skill's ``invalid_score`` for invalid
    successes and non-finite scores), so ``scores > 0`` are exactly the successes."""
    if not records:
        raise ValueError("no trial records")
    contexts = np.array([record.context for record in records], dtype=float)
    controls = np.array([record.control for record in records], dtype=float)
    scores = np.array([training_score(record, invalid_score) for record in records], dtype=float)
    valid = np.array([record.valid for record in records], dtype=bool)
    return contexts, controls, scores, valid
