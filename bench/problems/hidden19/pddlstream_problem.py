"""The hidden suite's YAML problems as PDDLStream problems (``PDDLProblem``), for PDDLStream
itself and for ltamp's drop-in API ``ltamp_cli.pddlstream``, with the same domain and stream
files and the same samplers (``<domain>/streams.py: plain_streams``).

Object values come from the YAML's ``objects`` (``null``: the name itself, lists: tuples),
init facts and the goal are its PDDL strings with names replaced by values. No planner hints
(no ``StreamInfo``) are given, as a user's first script would not give any.
"""

from __future__ import annotations

import importlib.util
import re
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import yaml

TOKEN = re.compile(r"\(|\)|[^\s()]+")


def _module(path: Path) -> ModuleType:
    spec = importlib.util.spec_from_file_location(f"hidden19_{path.parent.name}", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _value(raw: Any, name: str) -> Any:
    if raw is None:
        return name
    return tuple(raw) if isinstance(raw, list) else raw


def _parse(text: str, values: dict[str, Any]) -> Any:
    """An s-expression as nested tuples, object names replaced by their values."""
    tokens = TOKEN.findall(text)
    position = 0

    def read() -> Any:
        nonlocal position
        token = tokens[position]
        position += 1
        if token != "(":
            return values.get(token.lower(), token)
        items = []
        while tokens[position] != ")":
            items.append(read())
        position += 1
        head, *args = items
        return (head.lower() if head.lower() in ("and", "or", "not") else head, *args)

    return read()


def pddlstream_problem(path: Path, seed: int, api: dict[str, Callable[..., Any]]
                       ) -> tuple[Any, dict[str, Any]]:
    """``(PDDLProblem, planner options of the YAML)``. ``api``: ``PDDLProblem``,
    ``from_gen_fn``, ``from_fn``, ``from_test`` of the PDDLStream implementation to use."""
    doc = yaml.safe_load(path.read_text())
    folder = path.parent / doc["domain"]
    streams = _module(path.parent / doc["bindings"]).plain_streams(
        doc["world"], np.random.default_rng(seed))
    wrap = {"gen": api["from_gen_fn"], "fn": api["from_fn"], "test": api["from_test"],
            "function": lambda fn: fn}
    stream_map = {("Distance" if kind == "function" else name): wrap[kind](fn)
                  for name, (kind, fn) in streams.items()}
    values = {name.lower(): _value(raw, name.lower())
              for name, raw in (doc.get("objects") or {}).items()}
    init = [_parse(fact, values) for fact in doc["init"]]
    goal = _parse(doc["goal"], values)
    problem = api["PDDLProblem"]((folder / "domain.pddl").read_text(), {},
                                 (folder / "stream.pddl").read_text(), stream_map, init, goal)
    return problem, dict(doc.get("planner") or {})
