"""Round 3: inputs that never end or are huge. ``ltamp solve /dev/zero`` (or a ``.yaml`` /
``.pddl`` link to it) read until MemoryError (a traceback, after eating the memory); a YAML
problem of 3 MB (a long list under an unknown key) took over 3 min before its one-line
error. Problem files are now read with a size limit (YAML 1 MB, PDDL 64 MB): one line, at
once. The YAML text is also parsed once (nodes checked, then built) instead of twice."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from ltamp_cli.errors import InputError
from ltamp_cli.planner.problem import load_problem
from ltamp_cli.textfile import MAX_YAML_BYTES

REPO = Path(__file__).resolve().parents[2]
BLOCKS = (REPO / "problems/examples/blocksworld.yaml").read_text().replace(
    "../../domains", str(REPO / "domains"))


def test_a_yaml_problem_over_the_limit_is_refused_at_once(tmp_path: Path) -> None:
    path = tmp_path / "big.yaml"
    path.write_text(BLOCKS + "junk: [" + "1, " * (MAX_YAML_BYTES // 3) + "1]\n")
    with pytest.raises(InputError, match="larger than 1 MB") as error:
        load_problem(path)
    assert "\n" not in str(error.value) and str(path) in str(error.value)


def test_a_yaml_problem_under_the_limit_is_read(tmp_path: Path) -> None:
    path = tmp_path / "padded.yaml"
    path.write_text(BLOCKS + "# " + "x" * (MAX_YAML_BYTES - len(BLOCKS) - 100) + "\n")
    assert load_problem(path).name == "blocks8"


@pytest.mark.parametrize("name, domain", [("zero.yaml", False), ("zero.pddl", True),
                                          ("domain", True)])
def test_dev_zero_is_refused(tmp_path: Path, name: str, domain: bool) -> None:
    if not Path("/dev/zero").exists():
        pytest.skip("no /dev/zero")
    folder = tmp_path / "dom"
    folder.mkdir()
    problem = tmp_path / name
    if name == "domain":  # the domain file itself is the endless one
        (folder / "domain.pddl").symlink_to("/dev/zero")
        problem = tmp_path / "p.pddl"
        problem.write_text((REPO / "domains/blocksworld/blocks8.pddl").read_text())
    else:
        problem.symlink_to("/dev/zero")
        (folder / "domain.pddl").write_text(
            (REPO / "domains/blocksworld/domain.pddl").read_text())
    with pytest.raises(InputError, match="larger than") as error:
        load_problem(problem, folder if domain else None)
    assert "\n" not in str(error.value)


def test_cli_dev_zero_is_one_line() -> None:
    if not Path("/dev/zero").exists():
        pytest.skip("no /dev/zero")
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    run = subprocess.run([sys.executable, "-m", "ltamp_cli", "solve", "/dev/zero"],
                         capture_output=True, text=True, timeout=300, env=env)
    assert run.returncode == 2, run.stderr[-300:]
    assert len(run.stderr.strip().splitlines()) == 1, run.stderr[-300:]


def test_crlf_and_cr_only_yaml_still_read(tmp_path: Path) -> None:
    for newline in ("\r\n", "\r"):
        path = tmp_path / "crlf.yaml"
        path.write_bytes(BLOCKS.replace("\n", newline).encode())
        assert load_problem(path).name == "blocks8"
