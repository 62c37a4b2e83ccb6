"""Run a PDDLStream script unmodified: ``ltamp pddlstream run SCRIPT.py [ARGS...]`` or
``python -m ltamp_cli.pddlstream SCRIPT.py [ARGS...]``.

The script runs as ``__main__`` with :mod:`ltamp_cli.pddlstream.alias` installed, its own
folder first on ``sys.path`` and ``sys.argv == [SCRIPT, *ARGS]``, as ``python SCRIPT.py``
would run it, and with the NumPy-1 names NumPy 2 removed added back where NumPy 2 has an
exact equivalent (:mod:`ltamp_cli.pddlstream.numpy_compat`; ``--no-numpy-compat`` leaves
``numpy`` as installed). ``-m MODULE`` runs a module instead, with the current folder first on
``sys.path`` (as ``python -m MODULE``: PDDLStream's examples are run as
``python -m examples.continuous_tamp.run`` from its checkout).

Exit codes: the script's own (``sys.exit(n)``; 0 when it ends normally); 2 with one line on
stderr when the script needs a PDDLStream name ltamp does not provide, when ltamp rejects
the problem it was given (``InputError``: ``file:line:col`` for PDDL), or when the alias
cannot be installed (a real PDDLStream is importable: ``--force``); 1 with the script's
traceback when the script fails in its own code; 130 on Ctrl-C.
"""

from __future__ import annotations

import importlib.util
import os
import runpy
import sys
import traceback
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Protocol

from ltamp_cli.errors import InputError
from ltamp_cli.pddlstream.alias import (
    AliasAttributeError,
    AliasImportError,
    MissingEquivalentError,
    install,
    uninstall,
)
from ltamp_cli.pddlstream.numpy_compat import install as install_numpy_compat
from ltamp_cli.pddlstream.numpy_compat import uninstall as uninstall_numpy_compat

EXIT_SCRIPT_ERROR = 1
EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130

USAGE = ("usage: ltamp pddlstream run [--force] [--strict] [--no-numpy-compat] "
         "(SCRIPT.py | -m MODULE) [ARGS...]\n"
         "Run a PDDLStream script unmodified: its `pddlstream.*` imports are served by\n"
         "ltamp_cli.pddlstream. ARGS go to the script (sys.argv[1:]).\n"
         "  --force   shadow a real PDDLStream that is importable\n"
         "  --strict  PDDLStream names ltamp lacks fail at import, not at use\n"
         "  --no-numpy-compat  do not add back the NumPy-1 names NumPy 2 removed (np.mat,\n"
         "            np.product, np.float_, np.NaN, ...; see docs/porting-from-pddlstream.md)\n"
         "  -m MODULE run a module (current folder first on sys.path), as python -m")

class Writer(Protocol):
    """Where the runner's messages go (``sys.stderr`` or any object with ``write``)."""

    def write(self, text: str, /) -> int: ...


_RUNNER_FILES = (str(Path(__file__).resolve()), runpy.__file__)


def _user_frames(error: BaseException) -> traceback.StackSummary:
    """The traceback without the runner's own frames (runpy, this module) at its top."""
    frames = traceback.extract_tb(error.__traceback__)
    start = 0
    while start < len(frames) and (frames[start].filename in _RUNNER_FILES
                                   or frames[start].filename.startswith("<frozen runpy")):
        start += 1
    return traceback.StackSummary.from_list(frames[start:])


def _exit_code(done: SystemExit, stderr: Writer) -> int:
    """``sys.exit(code)`` as the interpreter maps it: None -> 0, int -> itself, else the
    text on stderr and 1."""
    if done.code is None:
        return 0
    if isinstance(done.code, int) and not isinstance(done.code, bool):
        return done.code
    print(done.code, file=stderr)
    return 1


def _check_module(name: str) -> None:
    """``InputError`` (one line) if the module ``name`` cannot be found (its parent packages
    are imported to look, as ``python -m`` does)."""
    try:
        spec = importlib.util.find_spec(name)
    except ModuleNotFoundError as error:
        if error.name and (name == error.name or name.startswith(error.name + ".")):
            raise InputError(f"-m {name}: no module named {error.name!r} (from "
                             f"{os.getcwd()})") from None
        raise
    if spec is None:
        raise InputError(f"-m {name}: no module named {name!r} (from {os.getcwd()})")


def run_target(target: str, argv: Sequence[str] = (), *, module: bool = False,
               force: bool = False, strict: bool = False, numpy_compat: bool = True,
               overrides: Mapping[str, Any] | None = None,
               stderr: Writer | None = None) -> int:
    """Run the script at path ``target`` (or the module named ``target`` if ``module``) as
    ``__main__`` with the alias installed and ``argv`` as its arguments; return its exit
    code (see the module docstring). ``sys.argv``, ``sys.path`` and the import system are
    restored afterwards (the modules the script imported, other than ``pddlstream.*``, stay
    in ``sys.modules`` as after any import). Raises :class:`InputError` if ``target`` is no
    script, or the alias cannot be installed. ``numpy_compat``: add back, while the script
    runs, the NumPy-1 names NumPy 2 removed that have an exact equivalent
    (:mod:`~ltamp_cli.pddlstream.numpy_compat`; removed again afterwards). ``overrides``: as in
    :func:`~ltamp_cli.pddlstream.alias.install`; ``stderr``: where the runner's messages go.
    """
    err: Writer = stderr if stderr is not None else sys.stderr
    if module:
        if not target or not all(part.isidentifier() for part in target.split(".")):
            raise InputError(f"-m {target!r}: not a module name (dotted identifiers)")
        search_dir = os.getcwd()
        argv0 = target
    else:
        path = Path(target)
        if not path.is_file():
            raise InputError(f"{target}: no such script" if not path.exists()
                             else f"{target}: not a file (a script is a .py file)")
        search_dir = str(path.resolve().parent)
        argv0 = str(path)
    saved_argv, saved_path = sys.argv, list(sys.path)
    sys.path.insert(0, search_dir)  # before install: a real PDDLStream there is detected
    try:
        finder = install(force=force, strict=strict, overrides=overrides)
    except BaseException:
        sys.path[:] = saved_path
        raise
    sys.argv = [argv0, *argv]
    compat = None
    try:
        if numpy_compat:
            compat = install_numpy_compat()
        if module:
            _check_module(target)
            runpy.run_module(target, run_name="__main__", alter_sys=True)
        else:
            runpy.run_path(str(path), run_name="__main__")
    except SystemExit as done:
        return _exit_code(done, err)
    except (AliasImportError, AliasAttributeError, MissingEquivalentError) as error:
        print(f"ltamp: error: {' '.join(str(error).split())}", file=err)
        return EXIT_BAD_INPUT
    except InputError as error:
        print(f"ltamp: error: {error}", file=err)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("ltamp: interrupted", file=err)
        return EXIT_INTERRUPTED
    except Exception as error:
        print("Traceback (most recent call last):", file=err)
        print("".join(_user_frames(error).format()), end="", file=err)
        print("".join(traceback.format_exception_only(type(error), error)), end="", file=err)
        print(f"ltamp: the script {argv0} failed in its own code ({type(error).__name__}, "
              "traceback above); exit code 1", file=err)
        return EXIT_SCRIPT_ERROR
    finally:
        sys.argv = saved_argv
        sys.path[:] = saved_path
        if compat is not None:
            uninstall_numpy_compat(compat)
        uninstall(finder)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m ltamp_cli.pddlstream [--force] [--strict] [--no-numpy-compat]
    (SCRIPT | -m MODULE) [ARGS...]``;
    returns the exit code."""
    args = list(sys.argv[1:] if argv is None else argv)
    force = strict = module = False
    numpy_compat = True
    while args and args[0].startswith("-"):
        option = args.pop(0)
        if option in ("-h", "--help"):
            print(USAGE)
            return 0
        if option == "--force":
            force = True
        elif option == "--strict":
            strict = True
        elif option == "--no-numpy-compat":
            numpy_compat = False
        elif option == "-m":
            module = True
            break
        elif option == "--":
            break
        else:
            print(f"ltamp: error: unknown option {option!r} (before the script; options after "
                  "it go to the script)", file=sys.stderr)
            return EXIT_BAD_INPUT
    if not args:
        print("ltamp: error: missing the script to run ("
              + ("-m MODULE" if module else "SCRIPT.py or -m MODULE") + ")", file=sys.stderr)
        return EXIT_BAD_INPUT
    try:
        return run_target(args[0], args[1:], module=module, force=force, strict=strict,
                          numpy_compat=numpy_compat)
    except InputError as error:
        print(f"ltamp: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("ltamp: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
