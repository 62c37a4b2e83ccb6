"""Every ``ltamp`` command shown in ``docs/*.md`` runs and exits 0.

Commands are the lines starting with ``ltamp `` inside fenced ```` ```bash ```` blocks; a line
ending in the comment ``# slow`` runs only in the slow suite. Fenced blocks whose info string
has ``file=PATH`` (e.g. ```` ```python file=my_domain/streams.py ````) are written to that path
first, so a page can build a domain and then solve it. Commands run in document order (later
ones use earlier outputs) as ``python -m ltamp_cli ...`` from a temporary directory where the
repository's ``problems/``, ``domains/`` and ``models/`` are symlinked, so relative output
paths in the docs land in that directory, never in the repository. A ``pip install PATH`` line
(a page's plugin package) installs into ``.site/`` of that directory, without dependencies,
and later commands see it on ``PYTHONPATH``.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[2]
DOCS = REPO_ROOT / "docs"
DOC_PAGES = ("tutorial.md", "writing-a-domain.md")
LINKED_FOLDERS = ("problems", "domains", "models")
OUTPUT_OPTIONS = ("--out", "--plot", "--render", "--curve")
FENCE = re.compile(r"^```(\S*)(.*)$")
SLOW_MARK = re.compile(r"#\s*slow\s*$")
FAST_TIMEOUT_S = 240
SLOW_TIMEOUT_S = 1800


@dataclass(frozen=True)
class DocCommand:
    """One ``ltamp`` command of a page: its arguments after ``ltamp`` and where it is."""

    page: str
    line: int
    argv: tuple[str, ...]
    slow: bool
    program: str = "ltamp"

    @property
    def where(self) -> str:
        return f"docs/{self.page}:{self.line}"

    def outputs(self) -> list[str]:
        """Paths given to output options (must exist after the command ran)."""
        return [self.argv[i + 1] for i, arg in enumerate(self.argv[:-1]) if arg in OUTPUT_OPTIONS]


@dataclass(frozen=True)
class DocPage:
    commands: tuple[DocCommand, ...]
    files: dict[str, str]


def parse_page(path: Path) -> DocPage:
    """Collect the commands of ``bash`` blocks and the ``file=`` blocks of one page."""
    commands: list[DocCommand] = []
    files: dict[str, str] = {}
    language: str | None = None
    target: str | None = None
    body: list[str] = []
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        fence = FENCE.match(line)
        if fence and language is None:
            language = fence.group(1)
            found = re.search(r"\bfile=(\S+)", fence.group(2))
            target = found.group(1) if found else None
            body = []
            continue
        if fence:
            if target is not None:
                files[target] = "\n".join(body) + "\n"
            language = None
            continue
        if language is None:
            continue
        body.append(line)
        stripped = line.strip()
        if language == "bash" and stripped.startswith("ltamp "):
            # Continuation lines would be silently cut: the docs keep each command on one line.
            assert not stripped.endswith("\\"), f"docs/{path.name}:{number}: one line per command"
            words = shlex.split(stripped, comments=True)
            commands.append(DocCommand(path.name, number, tuple(words[1:]),
                                       bool(SLOW_MARK.search(stripped))))
        elif language == "bash" and stripped.startswith("pip install "):
            words = shlex.split(stripped, comments=True)
            commands.append(DocCommand(path.name, number, tuple(words[2:]), False, "pip"))
    assert language is None, f"docs/{path.name}: unclosed code fence"
    return DocPage(tuple(commands), files)


def prepare_workspace(root: Path, page: DocPage) -> Path:
    for name in LINKED_FOLDERS:
        (root / name).symlink_to(REPO_ROOT / name, target_is_directory=True)
    for relative, text in page.files.items():
        destination = root / relative
        destination.parent.mkdir(parents=True, exist_ok=True)
        destination.write_text(text, encoding="utf-8")
    return root


def run_command(command: DocCommand, workdir: Path, timeout_s: float) -> None:
    site = workdir / ".site"
    if command.program == "pip":
        argv = [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                "--no-build-isolation", "--no-index", "--disable-pip-version-check",
                "--target", str(site), *command.argv]
    else:
        argv = [sys.executable, "-m", "ltamp_cli", *command.argv]
    paths = [str(site), str(REPO_ROOT), os.environ.get("PYTHONPATH", "")]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in paths if p))
    completed = subprocess.run(argv, cwd=workdir, env=env, capture_output=True, text=True,
                               timeout=timeout_s, check=False)
    assert completed.returncode == 0, (
        f"{command.where}: `{command.program} {shlex.join(command.argv)}` exited "
        f"{completed.returncode}\n"
        f"{completed.stderr[-2000:]}")
    for output in command.outputs():
        produced = workdir / output
        assert produced.exists(), f"{command.where}: {output} was not written"
        if produced.is_file():
            assert produced.stat().st_size > 0, f"{command.where}: {output} is empty"


def run_page(name: str, workdir: Path, include_slow: bool) -> int:
    page = parse_page(DOCS / name)
    prepare_workspace(workdir, page)
    ran = 0
    for command in page.commands:
        if command.slow and not include_slow:
            continue
        run_command(command, workdir, SLOW_TIMEOUT_S if command.slow else FAST_TIMEOUT_S)
        ran += 1
    return ran


def test_tutorial_covers_the_workflow() -> None:
    commands = parse_page(DOCS / "tutorial.md").commands
    verbs = [command.argv[0] for command in commands]
    for verb in ("skills", "train", "evaluate", "sample", "solve"):
        assert verb in verbs, f"the tutorial shows no `ltamp {verb}`"
    slow = {shlex.join(command.argv) for command in commands if command.slow}
    assert any("pour --backend box2d" in text for text in slow)
    assert any("coffee.yaml --backend box2d" in text and "--render" in text for text in slow)


def test_parser_reads_fences_files_and_slow_marks(tmp_path: Path) -> None:
    page = tmp_path / "page.md"
    page.write_text(
        "text\n```bash\npython3 -m venv .venv\nltamp solve 'a b.yaml' --out x  # slow\n```\n"
        "```text file=d/f.txt\nhello\n```\n```sh\nltamp skills\n```\n", encoding="utf-8")
    parsed = parse_page(page)
    assert parsed.commands == (DocCommand("page.md", 4, ("solve", "a b.yaml", "--out", "x"),
                                          True),)
    assert parsed.commands[0].outputs() == ["x"]
    assert parsed.files == {"d/f.txt": "hello\n"}


@pytest.mark.parametrize("name", DOC_PAGES)
def test_fast_doc_commands_exit_zero(name: str, tmp_path: Path) -> None:
    assert run_page(name, tmp_path, include_slow=False) > 0


@pytest.mark.slow
@pytest.mark.parametrize("name", DOC_PAGES)
def test_all_doc_commands_exit_zero(name: str, tmp_path: Path) -> None:
    assert run_page(name, tmp_path, include_slow=True) > 0
