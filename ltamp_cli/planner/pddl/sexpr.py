"""S-expression reader with source positions (1-based line and column)."""

from __future__ import annotations

from dataclasses import dataclass

from ltamp_cli.errors import InputError, SourceLocation


@dataclass(frozen=True)
class Symbol:
    """An atom of the s-expression: a name, variable, keyword or number."""

    text: str
    location: SourceLocation

    def __str__(self) -> str:
        return self.text


@dataclass(frozen=True)
class SList:
    """A parenthesised list; ``location`` is that of its opening parenthesis."""

    items: tuple[SExpr, ...]
    location: SourceLocation

    def __len__(self) -> int:
        return len(self.items)

    def head(self) -> str | None:
        """The lower-cased first symbol, or ``None`` when the list is empty or nested."""
        if self.items and isinstance(self.items[0], Symbol):
            return self.items[0].text.lower()
        return None

    def __str__(self) -> str:
        return "(" + " ".join(str(item) for item in self.items) + ")"


SExpr = Symbol | SList


# Lists nested deeper than this are bad input: the recursive parsers and checkers behind the
# reader would otherwise run out of stack (real domains nest a dozen levels).
MAX_DEPTH = 100


def read_sexprs(text: str, path: str, line_offset: int = 0, column_offset: int = 0) -> list[SExpr]:
    """Parse every top-level s-expression of ``text``.

    ``line_offset``/``column_offset`` shift reported positions, for PDDL embedded in another
    file (e.g. a YAML string). Comments start with ``;`` and run to the end of the line.
    Nesting deeper than :data:`MAX_DEPTH` is an :class:`InputError`.
    """
    stack: list[tuple[list[SExpr], SourceLocation]] = []
    top: list[SExpr] = []
    line, column = 1, 1
    # A byte-order mark (files saved by Windows editors) is not text: skip it.
    index, length = (1 if text.startswith("\ufeff") else 0), len(text)

    def here() -> SourceLocation:
        col = column + (column_offset if line == 1 else 0)
        return SourceLocation(path, line + line_offset, col)

    while index < length:
        char = text[index]
        if char == "\n":
            line, column = line + 1, 1
            index += 1
            continue
        if char.isspace():
            column += 1
            index += 1
            continue
        if char == ";":
            while index < length and text[index] != "\n":
                index += 1
            continue
        if char == "(":
            if len(stack) >= MAX_DEPTH:
                raise InputError(f"lists nested deeper than {MAX_DEPTH} levels", here())
            stack.append(([], here()))
            column += 1
            index += 1
            continue
        if char == ")":
            if not stack:
                raise InputError("unexpected ')': no list is open here", here())
            items, start = stack.pop()
            node = SList(tuple(items), start)
            (stack[-1][0] if stack else top).append(node)
            column += 1
            index += 1
            continue
        start_location = here()
        begin = index
        while index < length and not text[index].isspace() and text[index] not in "();":
            index += 1
        column += index - begin
        symbol = Symbol(text[begin:index], start_location)
        (stack[-1][0] if stack else top).append(symbol)
    if stack:
        raise InputError("unclosed '(': expected a matching ')' before the end", stack[-1][1])
    return top


def read_one(text: str, path: str, what: str) -> SList:
    """Parse text that must hold exactly one parenthesised expression (``what`` names it)."""
    exprs = read_sexprs(text, path)
    if not exprs:
        raise InputError(f"empty file: expected a {what}", SourceLocation(path, 1, 1))
    first = exprs[0]
    if not isinstance(first, SList):
        raise InputError(f"expected '(' starting a {what}", first.location)
    if len(exprs) > 1:
        raise InputError(f"unexpected text after the {what}", exprs[1].location)
    return first
