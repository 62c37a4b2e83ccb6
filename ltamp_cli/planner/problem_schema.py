"""The schema of YAML problem files (pydantic v2) and its one-line, positioned errors.

:func:`validate_problem_document` checks the *structure* of a problem file before anything is
loaded: unknown keys, wrong types and missing required fields become one
``file:line:column: field 'a.b.c': expected ...`` :class:`~ltamp_cli.errors.InputError`, the
position being that of the offending YAML node (or of its nearest existing parent for a
missing field). The meaning of the values (does the domain folder exist, do the facts parse,
does an object have a known type) is still checked by :mod:`ltamp_cli.planner.problem`.

``world`` blocks belong to the domain's bindings and the backend that builds the scene: only
their common structure is strict here (``learned_streams`` entries, ``models``, the
``objects`` and ``regions`` maps); every other ``world`` field is allowed and left to them.

The sampler, algorithm and search names are spelled out here (importing their modules would be
circular or pull in torch just to read a YAML file); ``tests/schema`` checks that they match.
"""

from __future__ import annotations

import types
import typing
from typing import Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ltamp_cli.errors import InputError
from ltamp_cli.yamlfile import YamlDocument

SAMPLER_NAMES = ("rejection", "adaptive", "diverse", "diverse-lk")
ALGORITHM_NAMES = ("adaptive", "binding", "focused", "incremental")
SEARCH_NAMES = ("ff", "lazy-greedy", "wastar", "fd", "fd-wastar")

# strict: no silent coercion ("3" is not an int, true is not a number); ints still count as
# floats. Strings are not stripped or lowered: values reach the bindings as written.
_STRICT = ConfigDict(strict=True, extra="forbid", populate_by_name=False)


class LearnedStreamEntry(BaseModel):
    """``world.learned_streams.<stream>``: which model and sampler a learned stream uses."""

    model_config = _STRICT

    model: str = Field(description="the path of a trained model directory")
    sampler: Literal[SAMPLER_NAMES] = "adaptive"  # type: ignore[valid-type]
    lam: float | None = Field(None, alias="lambda", gt=0.0, le=1.0,
                              description="relaxed-β λ in (0, 1]")
    beta: float | None = None
    kernel_file: str | None = None
    extrapolate: bool = Field(False, description="also sample contexts outside the model's "
                              "trained range (default: no samples there)")


class WorldObject(BaseModel):
    """``world.objects.<name>``: a scene object; ``kind`` is common, the rest is the backend's."""

    model_config = ConfigDict(strict=True, extra="allow")

    kind: str = Field(description="the object's kind (cup, bowl, block, ...)")


class World(BaseModel):
    """``world``: handed to the bindings' ``make_streams(world, rng)``; backend fields pass."""

    model_config = ConfigDict(strict=True, extra="allow")

    learned_streams: dict[str, LearnedStreamEntry] | None = None
    models: dict[str, str] | None = None
    objects: dict[str, WorldObject] | None = None
    # 1-D ranges [low, high] (tamp2d) or boxes [[x0, x1], [y0, y1]] (kitchen3d).
    regions: dict[str, list[float] | list[list[float]]] | None = None


class PlannerOptions(BaseModel):
    """``planner``: default options of ``ltamp solve`` (command-line options override them)."""

    model_config = _STRICT

    algorithm: Literal[ALGORITHM_NAMES] | None = None  # type: ignore[valid-type]
    max_time: float | None = Field(None, gt=0.0)
    seed: int | None = Field(None, ge=0)
    search: Literal[SEARCH_NAMES] | None = None  # type: ignore[valid-type]
    unit_costs: bool | None = None
    initial_complexity: int | None = Field(None, ge=0)
    max_complexity: int | None = Field(None, ge=0)
    success_cost: float | None = Field(None, ge=0.0)
    skeleton: list[str] | None = None
    # several skeletons: the plan follows one of them (PDDLStream's PlanConstraints)
    skeletons: list[list[str]] | None = None
    max_cost: float | None = Field(None, ge=0.0)  # only plans cheaper than this
    eager_cheap_streams: bool | None = None
    incremental_grounding: bool | None = None


class ProblemFile(BaseModel):
    """A YAML problem file (see :mod:`ltamp_cli.planner.problem` for the meaning of fields)."""

    model_config = _STRICT

    name: str | None = None
    description: str | None = None
    domain: str = Field(description="the domain folder (with domain.pddl)")
    bindings: str | None = None
    world: World | None = None
    # Object names and values are checked against the domain by the loader.
    objects: dict[Any, Any] | None = None
    init: list[str] | None = None
    goal: str | None = None
    pddl_problem: str | None = None
    planner: PlannerOptions | None = None
    # No `streams:` or `backend:` keys: nothing read them (a `backend: box2d` line did not
    # make `ltamp solve` execute anything; that is `--backend`), so they are unknown fields.


# ---- pydantic errors -> one positioned line -----------------------------------------------

_EXPECTED = {
    "string_type": "a string",
    "int_type": "an integer",
    "int_from_float": "an integer",
    "float_type": "a number",
    "bool_type": "true or false",
    "list_type": "a list",
    "dict_type": "a mapping",
    "model_type": "a mapping",
    "model_attributes_type": "a mapping",
    "none_required": "nothing (null)",
}
_BOUNDS = {"greater_than": ">", "greater_than_equal": ">=", "less_than": "<",
           "less_than_equal": "<="}


def _unwrap(annotation: Any) -> list[Any]:
    """The non-None members of a (possibly optional / union) annotation."""
    origin = typing.get_origin(annotation)
    if origin is typing.Union or origin is types.UnionType:
        return [a for a in typing.get_args(annotation) if a is not type(None)]
    return [annotation]


def _field(model: type[BaseModel], key: str) -> Any:
    for name, info in model.model_fields.items():
        if (info.alias or name) == key:
            return info
    return None


def _types_at(root: type[BaseModel], path: list[str | int]) -> list[Any]:
    """The annotations (union members, None dropped) that ``path`` leads to under ``root``."""
    current: list[Any] = [root]
    for key in path:
        following: list[Any] = []
        for option in current:
            if isinstance(option, type) and issubclass(option, BaseModel):
                info = _field(option, str(key))
                if info is not None:
                    following.extend(_unwrap(info.annotation))
            elif typing.get_origin(option) is dict:
                following.extend(_unwrap(typing.get_args(option)[1]))
            elif typing.get_origin(option) is list and isinstance(key, int):
                following.extend(_unwrap(typing.get_args(option)[0]))
        current = following
    return current


def _models_at(root: type[BaseModel], path: list[str | int]) -> list[type[BaseModel]]:
    return [t for t in _types_at(root, path) if isinstance(t, type) and issubclass(t, BaseModel)]


def _allowed_keys(root: type[BaseModel], path: list[str | int]) -> tuple[str, ...]:
    """Field names (aliases) of the model found at ``path`` under ``root``, or ``()``."""
    for model in _models_at(root, path):
        return tuple(info.alias or name for name, info in model.model_fields.items())
    return ()


def _description(root: type[BaseModel], path: list[str | int]) -> str:
    """The ``description`` of the field at ``path`` (what a missing field should hold)."""
    for model in _models_at(root, path[:-1]) if path else []:
        info = _field(model, str(path[-1]))
        if info is not None and info.description:
            return str(info.description)
    return ""


def _is_tag(key: str | int) -> bool:
    """Union member tags (``'list[float]'``) and the ``'[key]'`` marker name no YAML node."""
    return isinstance(key, str) and "[" in key


def _doc_path(doc: YamlDocument, loc: tuple[str | int, ...]) -> list[str | int]:
    """The part of pydantic's ``loc`` that names YAML nodes (plus a missing field's name)."""
    path: list[str | int] = []
    node: yaml.Node | None = doc.root
    for key in loc:
        if isinstance(node, yaml.MappingNode):
            child = next((v for k, v in node.value if k.value == str(key)), None)
            if child is not None:
                path.append(str(key))
            elif not _is_tag(key):
                path.append(key)  # a missing field: named, but it has no node
            node = child if child is not None else (None if not _is_tag(key) else node)
        elif isinstance(node, yaml.SequenceNode) and isinstance(key, int):
            if 0 <= key < len(node.value):
                path.append(key)
                node = node.value[key]
        elif node is None and not _is_tag(key):
            path.append(key)
    return path


def _dotted(path: list[str | int]) -> str:
    text = ""
    for key in path:
        text += f"[{key}]" if isinstance(key, int) else (f".{key}" if text else str(key))
    return text


def _got(value: Any) -> str:
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, bool) or value is None:
        return {True: "true", False: "false", None: "null"}[value]
    shown = repr(value)
    return shown if len(shown) <= 40 else shown[:37] + "..."


def _message(error: dict[str, Any], root: type[BaseModel], path: list[str | int]) -> str:
    kind = error["type"]
    ctx = error.get("ctx") or {}
    name = _dotted(path) or "(top level)"
    if kind == "extra_forbidden":
        allowed = _allowed_keys(root, path[:-1])
        return f"unknown field {name!r}: expected one of {', '.join(allowed)}"
    if kind == "missing":
        what = _description(root, path)
        return f"missing field {name!r}" + (f": expected {what}" if what else "")
    if kind == "literal_error":
        expected = f"one of {ctx.get('expected', '')}".replace(" or ", ", ")
    elif kind in _BOUNDS:
        bound = next(iter(v for k, v in ctx.items() if k in ("gt", "ge", "lt", "le")), "")
        expected = f"a number {_BOUNDS[kind]} {bound:g}"
    elif kind in _EXPECTED:
        expected = _EXPECTED[kind]
    else:
        expected = str(error.get("msg", "a valid value")).lower()
    return f"field {name!r}: expected {expected}, got {_got(error.get('input'))}"


def _rank(error: dict[str, Any]) -> tuple[int, int]:
    # Report the most specific mistake first: an unknown key or a missing field before a type
    # mismatch, and the deepest location (a union tries every member, the deepest failure is
    # usually what the user meant).
    order = {"extra_forbidden": 0, "missing": 1}
    return order.get(error["type"], 2), -len(error["loc"])


def validate_problem_document(doc: YamlDocument) -> ProblemFile:
    """Check ``doc`` against :class:`ProblemFile`; raise one positioned :class:`InputError`."""
    if not isinstance(doc.data, dict):
        raise doc.error("a problem file must be a YAML mapping with at least 'domain' and "
                        "'goal'")
    try:
        return ProblemFile.model_validate(doc.data)
    except ValidationError as failure:
        errors = sorted(failure.errors(include_url=False), key=_rank)
        first = errors[0]
        path = _doc_path(doc, tuple(first["loc"]))
        raise InputError(_message(first, ProblemFile, path), doc.location(*path)) from None
