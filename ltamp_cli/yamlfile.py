"""YAML files that remember where each value came from, for ``file:line:column`` errors."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from ltamp_cli.errors import InputError, SourceLocation
from ltamp_cli.textfile import MAX_YAML_BYTES, read_limited_text

MAX_YAML_DEPTH = 64


def _check_structure(root: yaml.Node | None, path: str) -> None:
    """Reject nesting deeper than :data:`MAX_YAML_DEPTH` and a key repeated in one mapping
    (YAML says keys are unique; PyYAML would silently keep the last value)."""
    stack: list[tuple[yaml.Node, int]] = [(root, 1)] if root is not None else []
    visited: set[int] = set()  # aliases share nodes: walk each once (no "billion laughs")
    while stack:
        node, depth = stack.pop()
        if id(node) in visited:
            continue
        visited.add(id(node))
        if depth > MAX_YAML_DEPTH:
            mark = node.start_mark
            raise InputError(f"invalid YAML: nested deeper than {MAX_YAML_DEPTH} levels",
                             SourceLocation(path, mark.line + 1, mark.column + 1))
        if isinstance(node, yaml.MappingNode):
            seen: set[str] = set()
            for key, value in node.value:
                if isinstance(key, yaml.ScalarNode):
                    if key.value in seen and key.tag != "tag:yaml.org,2002:merge":
                        mark = key.start_mark
                        raise InputError(f"duplicate key {key.value!r}",
                                         SourceLocation(path, mark.line + 1, mark.column + 1))
                    seen.add(key.value)
                stack.append((key, depth + 1))
                stack.append((value, depth + 1))
        elif isinstance(node, yaml.SequenceNode):
            stack.extend((item, depth + 1) for item in node.value)


class YamlDocument:
    """A parsed YAML document plus the source position of every node."""

    def __init__(self, path: str | Path, text: str | None = None) -> None:
        self.path = str(path)
        if text is None:
            text = read_limited_text(path, MAX_YAML_BYTES, "file")
        try:
            # one parse: the data is built from the checked nodes (as yaml.load does)
            loader = yaml.SafeLoader(text)
            try:
                self.root = loader.get_single_node()
                _check_structure(self.root, self.path)
                self.data = (loader.construct_document(self.root) if self.root is not None
                             else None)
            finally:
                loader.dispose()
        except RecursionError:
            raise InputError(f"invalid YAML: nested deeper than {MAX_YAML_DEPTH} levels",
                             SourceLocation(self.path)) from None
        except ValueError as error:  # a value PyYAML cannot build (an int of 5000 digits)
            raise InputError(f"invalid YAML: {error}", SourceLocation(self.path)) from None
        except yaml.MarkedYAMLError as error:
            mark = error.problem_mark or error.context_mark
            line, column = (mark.line + 1, mark.column + 1) if mark else (0, 0)
            problem = error.problem or "malformed YAML"
            raise InputError(f"invalid YAML: {problem}", SourceLocation(self.path, line, column)
                             ) from None
        except yaml.YAMLError as error:
            raise InputError(f"invalid YAML: {error}", SourceLocation(self.path)) from None

    def node(self, *keys: str | int) -> yaml.Node | None:
        node = self.root
        for key in keys:
            if isinstance(node, yaml.MappingNode):
                node = next((v for k, v in node.value if k.value == key), None)
            elif isinstance(node, yaml.SequenceNode) and isinstance(key, int):
                node = node.value[key] if 0 <= key < len(node.value) else None
            else:
                return None
            if node is None:
                return None
        return node

    def location(self, *keys: str | int) -> SourceLocation:
        """Where the value at ``keys`` starts (or its nearest existing parent)."""
        for depth in range(len(keys), -1, -1):
            node = self.node(*keys[:depth])
            if node is not None:
                return SourceLocation(self.path, node.start_mark.line + 1,
                                      node.start_mark.column + 1)
        return SourceLocation(self.path, 1, 1)

    def text_origin(self, *keys: str | int) -> tuple[int, int]:
        """(line offset, column offset) to report positions inside a scalar string."""
        node = self.node(*keys)
        if node is None:
            return 0, 0
        quoted = isinstance(node, yaml.ScalarNode) and node.style in ("'", '"')
        if isinstance(node, yaml.ScalarNode) and node.style in ("|", ">"):
            return node.start_mark.line + 1, node.start_mark.column
        return node.start_mark.line, node.start_mark.column + (1 if quoted else 0)

    def error(self, message: str, *keys: str | int) -> InputError:
        return InputError(message, self.location(*keys))

    def get(self, *keys: str | int, default: Any = None) -> Any:
        data = self.data
        for key in keys:
            in_list = isinstance(data, list) and isinstance(key, int) and 0 <= key < len(data)
            if in_list or (isinstance(data, dict) and key in data):
                data = data[key]
            else:
                return default
        return data
