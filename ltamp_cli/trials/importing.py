"""Import recorded trials (e.g. from a real robot) from CSV or JSONL into the trial format.

A row names every context and control parameter of the skill (physical units, the names
``ltamp skills`` prints) and either ``score`` or a measured ``fraction`` (turned into a score
by the backend's optional ``score_from_fraction(skill, fraction)``), plus optional ``valid``
(default true) and ``seed`` (default 0). CSV files have a header row; JSONL files hold one
JSON object per line with the same keys. Other columns are ignored.

Every row is validated before anything is written; the first bad value raises
:class:`~ltamp_cli.errors.InputError` naming ``file:line`` and the field.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ltamp_cli.backends.protocol import ParamSpace, SkillSpec
from ltamp_cli.errors import InputError, location_in
from ltamp_cli.textfile import not_a_file
from ltamp_cli.trials.record import MAX_SCORE_MAGNITUDE, TrialDataset, TrialRecord
from ltamp_cli.writer_lock import exclusive_writer

ScoreFromFraction = Callable[[str, float], float]
"""``(skill, fraction in [0, 1]) -> score``; ``score > 0`` means success."""

_TRUE = {"1", "true", "yes", "y", "t"}
_FALSE = {"0", "false", "no", "n", "f"}
# Imported bounds are measured on hardware: allow rounding in the last printed digits.
_BOUND_TOLERANCE = 1e-9


@dataclass(frozen=True)
class ImportSummary:
    """What :func:`import_file` did: rows read, records appended, duplicates skipped."""

    rows: int
    added: int
    skipped: int


def read_rows(path: Path) -> Iterator[tuple[int, Mapping[str, Any]]]:
    """``(line number, row)`` for every data row of a ``.csv`` or ``.jsonl`` file."""
    suffix = path.suffix.lower()
    if not path.is_file():
        raise InputError(not_a_file(path))
    if suffix == ".csv":
        yield from _csv_rows(path)
    elif suffix in (".jsonl", ".ndjson"):
        yield from _jsonl_rows(path)
    else:
        raise InputError(
            f"unknown trial file type {suffix or '(none)'!r}: expected .csv or .jsonl",
            location_in(path),
        )


def _text_errors(path: Path, rows: Iterator[tuple[int, Mapping[str, Any]]]
                 ) -> Iterator[tuple[int, Mapping[str, Any]]]:
    """``rows`` with undecodable bytes and CSV syntax errors as one :class:`InputError`."""
    line = 0
    try:
        for line, row in rows:
            yield line, row
    except UnicodeDecodeError as error:
        # the decoder reads blocks ahead of the rows: the line is where reading stopped
        raise InputError(f"not UTF-8 text (byte {error.object[error.start]:#x}): save the "
                         "file as UTF-8", location_in(path, line + 1, 1)) from None
    except csv.Error as error:
        raise InputError(f"invalid CSV: {error}", location_in(path, line + 1, 1)) from None


def _csv_rows(path: Path) -> Iterator[tuple[int, Mapping[str, Any]]]:
    return _text_errors(path, _csv_rows_raw(path))


def _csv_rows_raw(path: Path) -> Iterator[tuple[int, Mapping[str, Any]]]:
    # utf-8-sig: spreadsheet programs start CSV files with a byte-order mark, which would
    # otherwise become part of the first column's name ("missing field 'phase'")
    with path.open(newline="", encoding="utf-8-sig") as handle:
        reader = csv.reader(handle)
        header: list[str] | None = None
        for fields in reader:
            line = reader.line_num
            if not fields or all(not value.strip() for value in fields):
                continue
            if header is None:
                header = [name.strip() for name in fields]
                duplicated = sorted({n for n in header if header.count(n) > 1})
                if duplicated:
                    raise InputError(
                        f"column {duplicated[0]!r} appears twice in the header",
                        location_in(path, line, 1),
                    )
                continue
            if len(fields) != len(header):
                raise InputError(
                    f"row has {len(fields)} fields but the header names {len(header)}",
                    location_in(path, line, 1),
                )
            yield line, {name: value.strip() for name, value in zip(header, fields, strict=True)}
    if header is None:
        raise InputError("empty CSV file: expected a header row", location_in(path, 1, 1))


def _jsonl_rows(path: Path) -> Iterator[tuple[int, Mapping[str, Any]]]:
    return _text_errors(path, _jsonl_rows_raw(path))


def _jsonl_rows_raw(path: Path) -> Iterator[tuple[int, Mapping[str, Any]]]:
    with path.open(encoding="utf-8-sig") as handle:
        for line, text in enumerate(handle, start=1):
            if not text.strip():
                continue
            try:
                row = json.loads(text)
            except (ValueError, RecursionError) as error:
                raise InputError(f"invalid JSON: {error}", location_in(path, line, 1)) from None
            if not isinstance(row, dict):
                raise InputError(
                    f"expected a JSON object, got {type(row).__name__}",
                    location_in(path, line, 1),
                )
            yield line, row


def _number(row: Mapping[str, Any], name: str, where: tuple[Path, int]) -> float:
    if name not in row or row[name] is None or row[name] == "":
        raise InputError(f"missing field {name!r}", location_in(where[0], where[1], 1))
    value = row[name]
    try:
        if isinstance(value, bool):
            raise ValueError
        number = float(value)
    except (TypeError, ValueError):
        raise InputError(
            f"field {name!r}: expected a number, got {value!r}", location_in(where[0], where[1], 1)
        ) from None
    if not math.isfinite(number):
        raise InputError(
            f"field {name!r}: expected a finite number, got {value!r}",
            location_in(where[0], where[1], 1),
        )
    return number


def _vector(
    row: Mapping[str, Any], space: ParamSpace, where: tuple[Path, int]
) -> tuple[float, ...]:
    values = []
    for name, low, high in zip(space.names, space.lows, space.highs, strict=True):
        value = _number(row, name, where)
        if not low - _BOUND_TOLERANCE <= value <= high + _BOUND_TOLERANCE:
            raise InputError(
                f"field {name!r}: {value:g} is outside its bounds [{low:g}, {high:g}]",
                location_in(where[0], where[1], 1),
            )
        values.append(value)
    return tuple(values)


def _flag(row: Mapping[str, Any], name: str, default: bool, where: tuple[Path, int]) -> bool:
    value = row.get(name)
    if value is None or value == "":
        return default
    if isinstance(value, bool):
        return value
    text = str(value).strip().lower()
    if text in _TRUE:
        return True
    if text in _FALSE:
        return False
    raise InputError(
        f"field {name!r}: expected true/false (or 1/0), got {value!r}",
        location_in(where[0], where[1], 1),
    )


def _seed(row: Mapping[str, Any], where: tuple[Path, int]) -> int:
    if row.get("seed") is None or row.get("seed") == "":
        return 0
    number = _number(row, "seed", where)
    if number != int(number) or number < 0:
        raise InputError(
            f"field 'seed': expected an integer >= 0, got {row['seed']!r}",
            location_in(where[0], where[1], 1),
        )
    return int(number)


def _score(
    row: Mapping[str, Any],
    spec: SkillSpec,
    score_from_fraction: ScoreFromFraction | None,
    where: tuple[Path, int],
) -> float:
    if row.get("score") not in (None, ""):
        score = _number(row, "score", where)
        if abs(score) > MAX_SCORE_MAGNITUDE:  # training would refuse the record
            raise InputError(f"field 'score': {score:g} is beyond ±{MAX_SCORE_MAGNITUDE:g}",
                             location_in(where[0], where[1], 1))
        return score
    if row.get("fraction") in (None, ""):
        raise InputError(
            "missing field 'score' (or a measured 'fraction')", location_in(where[0], where[1], 1)
        )
    if score_from_fraction is None:
        raise InputError(
            "field 'fraction': this backend has no score function for a measured fraction; "
            "give a 'score' column instead",
            location_in(where[0], where[1], 1),
        )
    fraction = _number(row, "fraction", where)
    if not 0.0 <= fraction <= 1.0:
        raise InputError(
            f"field 'fraction': expected a value in [0, 1], got {fraction:g}",
            location_in(where[0], where[1], 1),
        )
    try:
        return float(score_from_fraction(spec.name, fraction))
    except ValueError as error:
        raise InputError(f"field 'fraction': {error}; give a 'score' column instead",
                         location_in(where[0], where[1], 1)) from None


def parse_trials(
    path: str | Path,
    spec: SkillSpec,
    score_from_fraction: ScoreFromFraction | None = None,
) -> list[TrialRecord]:
    """Validate every row of ``path`` and return one :class:`TrialRecord` per row.

    Records are tagged ``backend="import:<file name>"`` with ``info`` naming the source line.
    """
    path = Path(path)
    records = []
    for line, row in read_rows(path):
        where = (path, line)
        score = _score(row, spec, score_from_fraction, where)
        valid = _flag(row, "valid", True, where)
        if not valid and score > 0:  # learned as is, it would be a success that never ran
            raise InputError(f"field 'score': {score:g} > 0 is a success, but 'valid' says the "
                             "trial could not be run: give its score <= 0 (e.g. -1)",
                             location_in(path, line, 1))
        records.append(
            TrialRecord(
                skill=spec.name,
                context=_vector(row, spec.context, where),
                control=_vector(row, spec.control, where),
                score=score,
                valid=valid,
                seed=_seed(row, where),
                backend=f"import:{path.name}",
                info={"source": path.name, "line": line},
            )
        )
    if not records:
        raise InputError("no trial rows", location_in(path))
    return records


def _identity(record: TrialRecord) -> tuple[str, tuple[float, ...], tuple[float, ...], float]:
    score = record.score if math.isfinite(record.score) else float("nan")
    # NaN never equals itself: key invalid-score trials by a sentinel instead.
    return record.skill, record.context, record.control, score if score == score else -math.inf


def append_new(dataset: TrialDataset, records: Sequence[TrialRecord]) -> ImportSummary:
    """Append the records not already in ``dataset`` (same skill, context, control and score).

    All new records are written with one atomic append, so a re-run of the same import adds
    nothing. ``dataset``'s writer lock is held from reading what it holds to appending (as
    ``collect`` holds it): a second import, collection or training of the same file meanwhile
    is an :class:`InputError`, not a second copy of every trial.
    """
    with exclusive_writer(dataset.path, is_directory=False):
        seen = {_identity(r) for r in dataset.iter_records()}
        fresh = []
        for record in records:
            key = _identity(record)
            if key not in seen:
                seen.add(key)
                fresh.append(record)
        dataset.append(fresh)
    return ImportSummary(rows=len(records), added=len(fresh), skipped=len(records) - len(fresh))


def import_file(
    source: str | Path,
    spec: SkillSpec,
    out: str | Path,
    score_from_fraction: ScoreFromFraction | None = None,
) -> ImportSummary:
    """Parse ``source`` for skill ``spec`` and append its new trials to the JSONL ``out``."""
    records = parse_trials(source, spec, score_from_fraction)
    return append_new(TrialDataset(out), records)
