"""Problem files as other editors and tools write them. Before the fix: a domain.pddl or
stream.pddl starting with a byte-order mark (Windows editors) was refused ("expected '('",
although the YAML problem beside it with a BOM was read), and a YAML integer of 5000 digits
escaped as a ValueError traceback."""

from __future__ import annotations

import io
import sys
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

import redteam_problems as problems

from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError
from ltamp_cli.pddlstream import solve
from ltamp_cli.planner.problem import load_problem


def _cli(*args: str) -> tuple[int, list[str]]:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err), pytest.raises(SystemExit) as done:
        main(list(args))
    return int(done.value.code or 0), err.getvalue().strip().splitlines()


@pytest.mark.parametrize("name", ["domain.pddl", "stream.pddl"])
def test_byte_order_mark_in_pddl(tmp_path: Path, name: str) -> None:
    path = problems.write_yaml_problem(tmp_path, "conveyor")
    pddl = tmp_path / "domain" / name
    pddl.write_bytes(b"\xef\xbb\xbf" + pddl.read_bytes())
    code, lines = _cli("check", str(path))
    assert code == 0, lines
    code, lines = _cli("solve", str(path), "--max-time", "20", "--no-stats")
    assert code == 0, lines


def test_byte_order_mark_in_api_text(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(problems, "CONVEYOR_STREAMS", "\ufeff" + problems.CONVEYOR_STREAMS)
    problem, check = problems.conveyor_problem(tmp_path)
    solution = solve(problem, max_time=20, verbose=False)
    assert solution.plan is not None
    check(solution.plan)


def test_yaml_integer_too_long_for_python(tmp_path: Path) -> None:
    path = problems.write_yaml_problem(tmp_path, "conveyor")
    path.write_text(path.read_text().replace("{b1: null, b2: null}",
                                             "{b1: null, b2: null, big: " + "9" * 5000 + "}"))
    with pytest.raises(InputError, match="invalid YAML"):
        load_problem(path)
    for command in ("check", "solve"):
        code, lines = _cli(command, str(path))
        assert code == 2 and len(lines) == 1 and "invalid YAML" in lines[0], lines


BLOCKS = Path(__file__).resolve().parents[2] / "domains" / "blocksworld"


def test_metric_maximize_is_refused(tmp_path: Path) -> None:
    """(:metric maximize (total-cost)) was accepted and the cheapest plan returned."""
    from ltamp_cli.pddlstream import solve_from_pddl

    text = (BLOCKS / "blocks8.pddl").read_text().replace("(:metric minimize",
                                                         "(:metric maximize")
    assert "maximize" in text
    problem = tmp_path / "blocks_max.pddl"
    problem.write_text(text)
    with pytest.raises(InputError, match="only \\(:metric minimize"):
        solve_from_pddl((BLOCKS / "domain.pddl").read_text(), text)
    code, lines = _cli("solve", str(problem), "--domain", str(BLOCKS), "--no-stats")
    assert code == 2 and len(lines) == 1 and "metric" in lines[0], lines


# Round 5. Before: a UTF-16 or UTF-32 file with its byte-order mark (Windows Notepad's
# "Unicode"; YAML allows both) was refused ("'utf-8' codec can't decode byte 0xff"), and a
# Latin-1 byte was reported without its line and column.
@pytest.mark.parametrize("encoding", ["utf-16", "utf-16-be", "utf-32"])
@pytest.mark.parametrize("name", ["problem.yaml", "domain/domain.pddl", "domain/stream.pddl"])
def test_utf16_and_utf32_files_with_a_byte_order_mark(tmp_path: Path, encoding: str,
                                                      name: str) -> None:
    path = problems.write_yaml_problem(tmp_path, "conveyor")
    target = path if name == "problem.yaml" else tmp_path / name
    text = target.read_text()
    bom = "\ufeff" if encoding == "utf-16-be" else ""  # utf-16/utf-32 write their own
    target.write_bytes((bom + text).encode(encoding))
    assert load_problem(path).goal is not None
    code, lines = _cli("check", str(path))
    assert code == 0, lines


def test_a_byte_that_is_not_utf8_is_located(tmp_path: Path) -> None:
    path = problems.write_yaml_problem(tmp_path, "conveyor")
    lines = path.read_text().splitlines()
    lines[2] = lines[2] + "  # caf\xe9"
    path.write_bytes("\n".join(lines).encode("latin-1"))
    column = len(lines[2])
    with pytest.raises(InputError, match="byte 0xe9 is not UTF-8") as error:
        load_problem(path)
    assert str(error.value).startswith(f"{path}:3:{column}: ")
    code, out = _cli("solve", str(path), "--max-time", "5", "--no-stats")
    assert code == 2 and len(out) == 1 and f"{path}:3:{column}: " in out[0], out
