"""Fuzzing helpers shared by ``tests/fuzz/test_fuzz_inputs.py`` and ``bench/fuzz.py``.

Hypothesis strategies that mutate the shipped PDDL, stream and YAML problem texts (character
and token edits, dropped parentheses, renamed symbols) and build ``ltamp`` argument lists,
plus :func:`run_cli`, which calls the CLI in-process and classifies the outcome.
"""

from __future__ import annotations

import contextlib
import io
import os
import random
import re
import shutil
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from hypothesis import strategies as st

from ltamp_cli.cli.app import main

REPO = Path(__file__).resolve().parents[2]
# New cases every run; a failure names the seed, and LTAMP_FUZZ_SEED=N replays it.
FUZZ_SEED = int(os.environ.get("LTAMP_FUZZ_SEED", random.SystemRandom().randrange(2**32)))
EXAMPLES = sorted(p.name for p in (REPO / "problems" / "examples").glob("*.yaml"))
# Symbols, identifiers and numbers as one token; any other non-space character alone.
TOKEN = re.compile(r"[\w?:.\-]+|\S")
ODD_CHARS = "()[]{}?:-;#\"'\\\n\t ,.&*!|%@0123456789aZ\x00\u00e9\u4e2d"


@dataclass(frozen=True)
class Target:
    """One mutable file (relative to the sandbox) and the example problem that reads it."""

    file: str
    problem: str


def _targets() -> list[Target]:
    targets: list[Target] = []
    for name in EXAMPLES:
        problem = f"problems/examples/{name}"
        targets.append(Target(problem, problem))
        text = (REPO / problem).read_text()
        domain = re.search(r"^domain:\s*\.\./\.\./(\S+)", text, re.MULTILINE)
        assert domain is not None, problem
        for extra in ("domain.pddl", "stream.pddl"):
            if (REPO / domain[1] / extra).exists():
                targets.append(Target(f"{domain[1]}/{extra}", problem))
        pddl = re.search(r"^pddl_problem:\s*\.\./\.\./(\S+)", text, re.MULTILINE)
        if pddl is not None:
            targets.append(Target(pddl[1], problem))
    return targets


TARGETS = _targets()
PDDL_TARGETS = [t for t in TARGETS if t.file.endswith(".pddl")]
YAML_TARGETS = [t for t in TARGETS if t.file.endswith(".yaml")]


@contextlib.contextmanager
def sandbox() -> Iterator[Path]:
    """A temporary copy of ``domains/`` and ``problems/examples/`` (same relative layout)."""
    with tempfile.TemporaryDirectory(prefix="ltamp-fuzz-") as name:
        root = Path(name)
        shutil.copytree(REPO / "domains", root / "domains",
                        ignore=shutil.ignore_patterns("__pycache__"))
        shutil.copytree(REPO / "problems" / "examples", root / "problems" / "examples")
        yield root


def _mutate_once(draw: st.DrawFn, text: str) -> str:
    tokens = [(m.start(), m.end()) for m in TOKEN.finditer(text)]
    op = draw(st.sampled_from(("delete", "insert", "swap", "delete_token", "duplicate_token",
                               "swap_tokens", "drop_paren", "rename")))
    if not text or not tokens:
        op = "insert"
    if op in ("delete", "insert", "swap"):
        at = draw(st.integers(0, max(len(text) - 1, 0)))
        if op == "delete":
            return text[:at] + text[at + 1:]
        if op == "insert":
            return text[:at] + draw(st.sampled_from(ODD_CHARS)) + text[at:]
        return text[:at] + text[at + 1:at + 2] + text[at:at + 1] + text[at + 2:]
    if op == "drop_paren":
        parens = [i for i, c in enumerate(text) if c in "()"]
        if not parens:
            return text
        at = draw(st.sampled_from(parens))
        return text[:at] + text[at + 1:]
    index = draw(st.integers(0, len(tokens) - 1))
    start, end = tokens[index]
    if op == "delete_token":
        return text[:start] + text[end:]
    if op == "duplicate_token":
        return text[:end] + " " + text[start:end] + text[end:]
    if op == "swap_tokens":
        other = draw(st.integers(0, len(tokens) - 1))
        (a0, a1), (b0, b1) = sorted([tokens[index], tokens[other]])
        if a1 > b0:
            return text
        return text[:a0] + text[b0:b1] + text[a1:b0] + text[a0:a1] + text[b1:]
    # rename: every occurrence of one symbol becomes another (existing or new) symbol
    old = text[start:end]
    new = draw(st.one_of(st.sampled_from([text[s:e] for s, e in tokens]),
                         st.from_regex(r"[A-Za-z?:][\w\-]{0,6}", fullmatch=True)))
    return re.sub(rf"(?<![\w\-]){re.escape(old)}(?![\w\-])", lambda _: new, text)


@st.composite
def mutated_text(draw: st.DrawFn, text: str) -> str:
    """``text`` after 1–3 random edits."""
    for _ in range(draw(st.integers(1, 3))):
        text = _mutate_once(draw, text)
    return text


OPTION_VALUES = st.one_of(
    st.sampled_from(["", "0", "-1", "1e400", "nan", "inf", "-0.5", "focused", "ff", "fd",
                     "wastar", "adaptive", "* ...", "stack ? ?", "(", "pick-up a", "x" * 300]),
    st.text(alphabet="ab-_./?*( )0123456789", max_size=12),
)
SOLVE_OPTIONS = ("--algorithm", "--seed", "--search", "--domain", "--success-cost",
                 "--skeleton", "--backend")
SOLVE_FLAGS = ("--unit-costs", "--json", "--stats", "--no-stats", "--bogus", "-x")


@st.composite
def cli_arguments(draw: st.DrawFn, root: str) -> list[str]:
    """An ``ltamp check|solve`` argument list; solve always ends with a short time limit."""
    command = draw(st.sampled_from(["check", "solve", "solve", "nosuchcommand", ""]))
    problem = draw(st.one_of(
        st.sampled_from([f"{root}/problems/examples/{n}" for n in EXAMPLES]),
        st.sampled_from([f"{root}/domains/blocksworld/domain.pddl",
                         f"{root}/domains/blocksworld/blocks8.pddl", f"{root}/domains",
                         f"{root}/missing.yaml", f"{root}/domains/tamp2d/streams.py", ""]),
    ))
    args = [command, problem] if command else [problem]
    for _ in range(draw(st.integers(0, 4))):
        if draw(st.booleans()):
            args += [draw(st.sampled_from(SOLVE_OPTIONS)), draw(OPTION_VALUES)]
        else:
            args.append(draw(st.sampled_from(SOLVE_FLAGS)))
    if draw(st.integers(0, 9)) == 0:  # sometimes shuffle everything, command included
        args = draw(st.permutations(args))
    if command == "solve":
        args += ["--max-time", "0.2", "--no-stats"]
    return args


@dataclass(frozen=True)
class Outcome:
    code: int
    stdout: str
    stderr: str


def run_cli(args: list[str]) -> Outcome:
    """Call ``ltamp`` in-process with captured output (any other exception propagates)."""
    out, err = io.StringIO(), io.StringIO()
    code: int | str | None = 0
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            main(args)
        except SystemExit as done:
            code = done.code
    if not isinstance(code, int):
        code = 0 if code is None else 1
    return Outcome(code, out.getvalue(), err.getvalue())


def acceptable(outcome: Outcome) -> str | None:
    """``None`` if the outcome is allowed, else why not."""
    if "Traceback" in outcome.stderr or "Traceback" in outcome.stdout:
        return "traceback in output"
    if outcome.code in (0, 1):
        return None
    if outcome.code != 2:
        return f"exit code {outcome.code}"
    lines = outcome.stderr.strip().splitlines()
    if len(lines) != 1:
        return f"{len(lines)} stderr lines instead of 1"
    return None


def run_mutated(root: Path, target: Target, text: str, argv_tail: list[str] | None = None,
                command: str = "check") -> Outcome:
    """Write ``text`` over ``target.file`` in the sandbox, run ``command`` (``check`` or
    ``solve``, which then gets a short time limit and no statistics) on its problem, restore."""
    path = root / target.file
    original = path.read_text()
    path.write_text(text, encoding="utf-8")
    tail = ["--max-time", "0.5", "--no-stats"] if command == "solve" else []
    try:
        return run_cli([command, str(root / target.problem), *tail, *(argv_tail or [])])
    finally:
        path.write_text(original)
