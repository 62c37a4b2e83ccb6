"""``ltamp check``: validate a problem, its domain, streams and bindings without solving."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

import typer

from ltamp_cli.errors import InputError, SourceLocation


def register(app: typer.Typer) -> None:
    app.command("check")(check_command)


@dataclass(frozen=True)
class CheckSummary:
    """Counts of a problem that loaded and whose bindings resolved."""

    domain: str
    actions: int
    streams: int
    objects: int
    init_facts: int

    def line(self) -> str:
        return (f"ok: domain {self.domain}  actions: {self.actions}  streams: {self.streams}  "
                f"objects: {self.objects}  init facts: {self.init_facts}")


def check_problem_file(path: Path, domain_dir: Path | None = None, seed: int = 0
                       ) -> CheckSummary:
    """Load ``path`` (checks domain, streams, types, arities, bindings import), build the
    bindings with ``make_streams(world, rng)`` and check every declared stream has one.

    Raises :class:`InputError` on any problem.
    """
    import numpy as np

    from ltamp_cli.planner.problem import load_problem
    from ltamp_cli.planner.streams import resolve_bindings
    from ltamp_cli.seeds import usable_seed

    loaded = load_problem(path, domain_dir)
    where = SourceLocation(str(path))
    streams = 0
    if loaded.stream_file is not None:
        # the file's own streams: not the negated tests the loader adds (pddl/negation.py)
        streams = len(loaded.stream_file.external_names()) - sum(
            1 for external in (*loaded.stream_file.streams, *loaded.stream_file.predicates)
            if external.negates)
        if loaded.streams_factory is not None:
            try:
                provided = loaded.streams_factory(dict(loaded.world),
                                                  np.random.default_rng(usable_seed(seed)))
            except (InputError, KeyboardInterrupt):
                raise
            except BaseException as error:  # user code (even SystemExit): never a traceback
                raise InputError(f"make_streams of {loaded.bindings_source!r} failed: "
                                 f"{type(error).__name__}: {error}", where) from None
            if not isinstance(provided, Mapping):
                raise InputError(f"make_streams of {loaded.bindings_source!r} must return a "
                                 "mapping of stream name to callable", where)
            try:
                resolve_bindings(loaded.stream_file, provided, repr(loaded.bindings_source))
            except InputError as error:
                raise InputError(error.message, error.location or where) from None
    init_facts = len(loaded.init) + len(loaded.function_values)
    return CheckSummary(loaded.domain.name, len(loaded.domain.actions), streams,
                        len(loaded.objects), init_facts)


def check_command(
    problem: Annotated[Path, typer.Argument(
        help="Problem file (.yaml, or .pddl with --domain), or a built-in name.")],
    domain: Annotated[Path | None, typer.Option(
        help="Domain folder, for a .pddl problem file.")] = None,
    seed: Annotated[int, typer.Option(help="Seed passed to make_streams.")] = 0,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object.")] = False,
) -> None:
    """Validate PROBLEM, its domain, streams and bindings; exit 0 if valid, 2 otherwise.

    PROBLEM is a file or a built-in name (see `ltamp problems`).
    """
    from dataclasses import asdict

    from ltamp_cli.cli.conventions import emit

    summary = check_problem_file(problem, domain, seed)
    emit({"ok": True, "problem": str(problem), **asdict(summary)}, as_json,
         lambda _: [summary.line()])
