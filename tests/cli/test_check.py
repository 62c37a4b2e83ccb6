"""``ltamp check``: shipped problems validate; broken ones exit 2 with one located line."""

from __future__ import annotations

import re
import textwrap
from pathlib import Path

import pytest

from ltamp_cli.cli.app import main

REPO = Path(__file__).resolve().parents[2]
SHIPPED = sorted((REPO / "problems").glob("*/*.yaml"))
DOMAIN = """\
(define (domain tiny)
  (:predicates (Thing ?x) (Done ?x))
  (:action finish :parameters (?x) :precondition (Thing ?x) :effect (Done ?x)))
"""
STREAMS = """\
(define (stream tiny)
  (:stream make-thing :outputs (?x) :certified (Thing ?x)))
"""
PROBLEM = """\
name: tiny
domain: dom
bindings: bindings.py
objects:
  a: null
init:
  - (Thing a)
goal: (Done a)
"""


def run(capsys: pytest.CaptureFixture[str], *args: str | Path) -> tuple[int, str, str]:
    with pytest.raises(SystemExit) as done:
        main(["check", *map(str, args)])
    out, err = capsys.readouterr()
    return int(done.value.code or 0), out, err


def write_problem(tmp_path: Path, problem: str = PROBLEM, domain: str = DOMAIN,
                  streams: str = STREAMS,
                  bindings: str = "def make_streams(world, rng):\n"
                                  "    return {'make-thing': lambda: iter([(1,)])}\n") -> Path:
    (tmp_path / "dom").mkdir()
    (tmp_path / "dom" / "domain.pddl").write_text(domain)
    (tmp_path / "dom" / "stream.pddl").write_text(streams)
    (tmp_path / "bindings.py").write_text(bindings)
    path = tmp_path / "problem.yaml"
    path.write_text(textwrap.dedent(problem))
    return path


def assert_bad(code: int, err: str, *fragments: str) -> str:
    assert code == 2, err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("ltamp: error: "), lines[0]
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    return lines[0].removeprefix("ltamp: error: ")


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_every_shipped_problem_checks(capsys: pytest.CaptureFixture[str], path: Path) -> None:
    code, out, err = run(capsys, path)
    assert code == 0, err
    match = re.fullmatch(r"ok: domain (\S+)  actions: (\d+)  streams: (\d+)  objects: (\d+)  "
                         r"init facts: (\d+)", out.strip())
    assert match, out
    assert int(match[2]) > 0 and int(match[4]) > 0 and int(match[5]) > 0
    # The stream count is what the domain's stream file declares (0 without one).
    stream_file = (path.parent / path.read_text().split("domain: ", 1)[1].split()[0]
                   / "stream.pddl")
    declared = stream_file.read_text() if stream_file.exists() else ""
    assert int(match[3]) == len(re.findall(r"\(:(?:stream|function|predicate)\b", declared))


def test_tiny_problem_summary_counts(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    code, out, err = run(capsys, write_problem(tmp_path))
    assert code == 0, err
    assert out.strip() == "ok: domain tiny  actions: 1  streams: 1  objects: 1  init facts: 1"


def test_missing_binding_names_the_stream(capsys: pytest.CaptureFixture[str],
                                          tmp_path: Path) -> None:
    path = write_problem(tmp_path, bindings="def make_streams(world, rng):\n    return {}\n")
    line = assert_bad(*run(capsys, path)[::2], "make-thing", "no Python binding")
    assert line.startswith(f"{tmp_path / 'dom' / 'stream.pddl'}:2:3: "), line


def test_make_streams_crash_is_one_line(capsys: pytest.CaptureFixture[str],
                                        tmp_path: Path) -> None:
    path = write_problem(tmp_path, bindings="def make_streams(world, rng):\n"
                                            "    return world['missing']\n")
    assert_bad(*run(capsys, path)[::2], "make_streams", "KeyError", str(path))


def test_unknown_predicate_in_init_has_line_and_column(capsys: pytest.CaptureFixture[str],
                                                       tmp_path: Path) -> None:
    path = write_problem(tmp_path, PROBLEM.replace("(Thing a)", "(Thnig a)"))
    line = assert_bad(*run(capsys, path)[::2], "thnig")
    assert re.match(re.escape(str(path)) + r":7:\d+: ", line), line


def test_broken_domain_has_line_and_column(capsys: pytest.CaptureFixture[str],
                                           tmp_path: Path) -> None:
    path = write_problem(tmp_path, domain=DOMAIN.replace("(Thing ?x) :effect", "(Thing ?x :effect"))
    line = assert_bad(*run(capsys, path)[::2])
    assert re.match(re.escape(str(tmp_path / "dom" / "domain.pddl")) + r":\d+:\d+: ", line), line


def test_bad_yaml_has_line(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = write_problem(tmp_path, PROBLEM.replace("goal: (Done a)", "goal: [(Done a)"))
    line = assert_bad(*run(capsys, path)[::2])
    assert re.match(re.escape(str(path)) + r":\d+:\d+: ", line), line


def test_missing_file_exits_2(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    assert_bad(*run(capsys, tmp_path / "nope.yaml")[::2], "nope.yaml")
