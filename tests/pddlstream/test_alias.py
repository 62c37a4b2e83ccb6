"""ltamp_cli.pddlstream.alias in this process: opt-in only, what it serves, what it refuses,
and that uninstall leaves the import system as it found it."""

from __future__ import annotations

import importlib
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from ltamp_cli.pddlstream import alias
from ltamp_cli.pddlstream.alias import (
    MISSING,
    SERVED,
    AliasConflictError,
    AliasImportError,
    MissingEquivalentError,
    MissingName,
)

REPO = Path(__file__).resolve().parents[2]


def pddlstream_modules() -> list[str]:
    return sorted(n for n in sys.modules if n == "pddlstream" or n.startswith("pddlstream."))


@pytest.fixture(autouse=True)
def clean_import_system() -> Iterator[None]:
    """Every test starts and must end without an alias or a pddlstream module."""
    assert not alias.is_installed() and pddlstream_modules() == []
    meta_path = list(sys.meta_path)
    yield
    leaked = alias.uninstall()
    assert not leaked, "a test left the alias installed"
    assert sys.meta_path == meta_path and pddlstream_modules() == []


def test_importing_ltamp_installs_nothing() -> None:
    """A fresh interpreter: importing ltamp_cli, the drop-in API, the alias module, the
    runner and the CLI app leaves sys.meta_path and sys.modules['pddlstream'] untouched."""
    code = (
        "import sys\n"
        "before = list(sys.meta_path)\n"
        "import ltamp_cli, ltamp_cli.pddlstream, ltamp_cli.pddlstream.alias\n"
        "import ltamp_cli.pddlstream.run, ltamp_cli.pddlstream.helpers\n"
        "from ltamp_cli.cli.app import build_app\n"
        "build_app()\n"
        "assert sys.meta_path == before, sys.meta_path\n"
        "assert not [m for m in sys.modules if m.split('.')[0] == 'pddlstream'], 'module'\n"
        "try:\n"
        "    import pddlstream.algorithms.meta\n"
        "except ImportError:\n"
        "    print('not importable')\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120, cwd=REPO / "tests",
                         env={"PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1",
                              "PATH": "/usr/bin:/bin"})
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "not importable"


def test_served_modules_resolve_to_ltamp_objects() -> None:
    import ltamp_cli.pddlstream as api
    from ltamp_cli.pddlstream import helpers

    with alias.installed():
        for module_name, names in SERVED.items():
            module = importlib.import_module(module_name)
            for name in names:
                value = getattr(module, name)
                expected = getattr(helpers, name, None)
                if expected is None:
                    expected = getattr(api, name)
                assert value is expected, f"{module_name}.{name}"
        from pddlstream.algorithms.meta import solve
        from pddlstream.language.generator import from_gen_fn
        from pddlstream.utils import get_file_path, read

        assert solve is api.solve and from_gen_fn is api.from_gen_fn
        assert read is api.read and get_file_path is api.get_file_path


def test_missing_names_import_and_fail_on_use_with_one_line() -> None:
    with alias.installed():
        from pddlstream.language.optimizer import OptimizerOutput

        assert isinstance(OptimizerOutput, MissingName)
        with pytest.raises(MissingEquivalentError) as raised:
            OptimizerOutput(assignments=[])
        line = sys._getframe().f_lineno - 1
        message = str(raised.value)
        assert "\n" not in message
        assert message.startswith(f"{__file__}:{line}: pddlstream.language.optimizer."
                                  "OptimizerOutput is not provided by ltamp's pddlstream alias")
        assert ":stream generator" in message  # what to use instead
        with pytest.raises(MissingEquivalentError, match="DebugValue"):
            from pddlstream.language.object import DebugValue

            isinstance(3, DebugValue)
    # Every missing name has a hint and lives in a served module.
    for module_name, hints in MISSING.items():
        assert module_name in SERVED
        assert all(hint and "\n" not in hint for hint in hints.values())


def test_strict_fails_at_import() -> None:
    with alias.installed(strict=True), pytest.raises(AliasImportError) as raised:
        from pddlstream.algorithms.skeleton import SkeletonQueue  # noqa: F401
    assert "pddlstream.algorithms.skeleton.SkeletonQueue is not provided" in str(raised.value)


def test_unknown_names_and_modules_raise_one_import_error_line() -> None:
    with alias.installed():
        with pytest.raises(AliasImportError) as raised:
            from pddlstream.utils import no_such_helper  # noqa: F401
        assert "cannot import 'no_such_helper' from pddlstream.utils" in str(raised.value)
        with pytest.raises(ModuleNotFoundError) as missing_module:
            import pddlstream.algorithms.no_such_module  # noqa: F401
        assert isinstance(missing_module.value, AliasImportError)
        assert "no module 'pddlstream.algorithms.no_such_module'" in str(missing_module.value)
        assert "\n" not in str(raised.value) + str(missing_module.value)
        import pddlstream.utils as utils

        assert not hasattr(utils, "no_such_helper") and hasattr(utils, "read")
        with pytest.raises(AttributeError, match=r"pddlstream\.utils has no attribute 'nope'"):
            utils.nope  # noqa: B018


def test_switch_modules_accept_flags_and_submodule_imports() -> None:
    with alias.installed():
        import pddlstream.language.exogenous as exogenous
        from pddlstream.algorithms import instantiate_task, refinement

        instantiate_task.FD_INSTANTIATE = True
        refinement.CONSTRAIN_PLANS = False
        exogenous.EXOGENOUS_AXIOMS = True
        with pytest.raises(AttributeError, match="planner switches"):
            exogenous.REPLACE_STREAM  # noqa: B018  (never set: nothing to read)
        assert not hasattr(exogenous, "REPLACE_STREAM") and exogenous.EXOGENOUS_AXIOMS


def test_refuses_to_shadow_a_real_pddlstream_unless_forced(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    real = tmp_path / "pddlstream"
    real.mkdir()
    (real / "__init__.py").write_text("REAL = True\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(AliasConflictError) as refused:
        alias.install()
    assert str(real / "__init__.py") in str(refused.value) and "force" in str(refused.value)
    assert not alias.is_installed()
    import pddlstream

    assert pddlstream.REAL
    with alias.installed(force=True):
        import pddlstream as served
        from pddlstream.algorithms.meta import solve

        assert served is not pddlstream and not hasattr(served, "REAL") and callable(solve)
    assert sys.modules["pddlstream"] is pddlstream  # the real one is back
    del sys.modules["pddlstream"]


def test_install_twice_and_unknown_override_are_refused() -> None:
    with alias.installed(), pytest.raises(AliasConflictError, match="already installed"):
        alias.install()
    with pytest.raises(alias.InputError, match="no_such_name"):
        alias.install(overrides={"no_such_name": print})
    assert not alias.is_installed()


def test_overrides_are_served_everywhere_the_name_is() -> None:
    def recording_solve(*args: object, **kwargs: object) -> str:
        return "recorded"

    with alias.installed(overrides={"solve": recording_solve}):
        from pddlstream.algorithms.meta import solve

        assert solve is recording_solve
    with alias.installed():
        from pddlstream.algorithms.meta import solve as plain

        assert plain is not recording_solve
