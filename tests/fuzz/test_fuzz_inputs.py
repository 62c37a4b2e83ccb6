"""Fuzz: mutated PDDL, stream and YAML files and odd CLI arguments never crash ``ltamp``.

Every in-process call must exit 0/1 (a mutation can stay valid) or 2 with exactly one line on
stderr, and never print a traceback. About 400 new cases every run (``check`` and ``solve``;
the seed is in the failure message, ``LTAMP_FUZZ_SEED=N`` replays it); ``bench/fuzz.py`` runs
the same strategies with many more, and ``test_hostile_inputs.py`` runs subprocesses.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import seed as hypothesis_seed
from hypothesis import strategies as st
from ltamp_fuzz import (
    FUZZ_SEED,
    PDDL_TARGETS,
    YAML_TARGETS,
    Target,
    acceptable,
    cli_arguments,
    mutated_text,
    run_cli,
    run_mutated,
    sandbox,
)

FUZZ = settings(deadline=None, database=None, print_blob=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                       HealthCheck.function_scoped_fixture])


@pytest.fixture(scope="module")
def root() -> Iterator[Path]:
    with sandbox() as path:
        yield path


@st.composite
def file_mutation(draw: st.DrawFn, targets: list[Target], root: Path) -> tuple[Target, str]:
    target = draw(st.sampled_from(targets))
    return target, draw(mutated_text((root / target.file).read_text()))


def _check(root: Path, targets: list[Target], data: st.DataObject,
           command: str = "check") -> None:
    target, text = data.draw(file_mutation(targets, root))
    outcome = run_mutated(root, target, text, command=command)
    problem = acceptable(outcome)
    assert problem is None, (f"LTAMP_FUZZ_SEED={FUZZ_SEED}", problem, target, outcome)


@hypothesis_seed(FUZZ_SEED)
@settings(FUZZ, max_examples=160)
@given(data=st.data())
def test_mutated_pddl_files(root: Path, data: st.DataObject) -> None:
    _check(root, PDDL_TARGETS, data)


@hypothesis_seed(FUZZ_SEED)
@settings(FUZZ, max_examples=110)
@given(data=st.data())
def test_mutated_yaml_problems(root: Path, data: st.DataObject) -> None:
    _check(root, YAML_TARGETS, data)


@hypothesis_seed(FUZZ_SEED)
@settings(FUZZ, max_examples=60)
@given(data=st.data())
def test_mutated_files_solved(root: Path, data: st.DataObject) -> None:
    _check(root, PDDL_TARGETS + YAML_TARGETS, data, command="solve")


@hypothesis_seed(FUZZ_SEED)
@settings(FUZZ, max_examples=100)
@given(data=st.data())
def test_odd_cli_arguments(root: Path, data: st.DataObject) -> None:
    args = data.draw(cli_arguments(str(root)))
    outcome = run_cli(args)
    problem = acceptable(outcome)
    assert problem is None, (f"LTAMP_FUZZ_SEED={FUZZ_SEED}", problem, args, outcome)


def test_fuzz_can_fail(root: Path) -> None:
    """The oracle rejects what it must: tracebacks, multi-line errors, odd exit codes."""
    from ltamp_fuzz import Outcome

    assert acceptable(Outcome(2, "", "ltamp: error: x\n")) is None
    assert acceptable(Outcome(2, "", "a\nb\n")) is not None
    assert acceptable(Outcome(1, "", "Traceback (most recent call last):\n")) is not None
    assert acceptable(Outcome(3, "", "")) is not None
    # A dropped parenthesis in a shipped domain is caught as bad input, with a location.
    target = PDDL_TARGETS[0]
    text = (root / target.file).read_text()
    outcome = run_mutated(root, target, text[: text.rindex(")")])
    assert outcome.code == 2 and target.file.split("/")[-1] in outcome.stderr, outcome
