"""JSON data files read as data only: bounded nesting, no NaN/Infinity, one-line errors."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from ltamp_cli.errors import InputError, location_in

MAX_JSON_DEPTH = 64


def json_depth(text: str) -> int:
    """Deepest ``[``/``{`` nesting of JSON ``text`` (brackets inside strings ignored)."""
    depth = deepest = 0
    in_string = escaped = False
    for char in text:
        if in_string:
            if escaped:
                escaped = False
            elif char == "\\":
                escaped = True
            elif char == '"':
                in_string = False
        elif char == '"':
            in_string = True
        elif char in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif char in "]}":
            depth -= 1
    return deepest


def _reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a number JSON data may hold")


def _finite_float(text: str) -> float:
    value = float(text)
    if value in (float("inf"), float("-inf")):
        raise ValueError(f"{text} overflows a float")
    return value


def parse_json_data(text: str, path: str | Path, max_depth: int = MAX_JSON_DEPTH) -> Any:
    """Parse ``text`` read from ``path``; deep nesting, NaN/Infinity and bad JSON raise
    :class:`InputError` naming ``path``."""
    if json_depth(text) > max_depth:
        raise InputError(f"JSON nested deeper than {max_depth} levels", location_in(path))
    try:
        return json.loads(text, parse_constant=_reject_constant, parse_float=_finite_float)
    except json.JSONDecodeError as error:
        raise InputError(f"invalid JSON: {error.msg}",
                         location_in(path, error.lineno, error.colno)) from None
    except (ValueError, RecursionError) as error:
        raise InputError(f"invalid JSON: {error}", location_in(path)) from None


def read_json_data(path: str | Path, max_depth: int = MAX_JSON_DEPTH) -> Any:
    """Read and parse the JSON file ``path`` like :func:`parse_json_data`."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise InputError(f"cannot read file: {error}", location_in(path)) from None
    return parse_json_data(text, path, max_depth)
