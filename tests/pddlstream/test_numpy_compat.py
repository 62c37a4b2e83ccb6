"""The runner's NumPy-1 compatibility layer (ltamp_cli.pddlstream.numpy_compat): a script
written for NumPy 1 runs unmodified, ``--no-numpy-compat`` switches it off, nothing outside
the runner patches numpy, an existing attribute is never replaced, and the restored names
compute exactly what NumPy 1 computed."""

from __future__ import annotations

import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest
from numpy1_scripts import write_shelf
from runner_subprocess import run_runner as run

from ltamp_cli.pddlstream import numpy_compat
from ltamp_cli.pddlstream.numpy_compat import LEGACY, NOT_RESTORED, installed

REPO = Path(__file__).resolve().parents[2]
PLAN_LINE = "1) store crate [1.5 2.5 3. ]"


def numpy_lacks(name: str) -> bool:
    return not hasattr(np, name)


needs_numpy2 = pytest.mark.skipif(not numpy_lacks("mat"),
                                  reason="the installed NumPy still has numpy.mat")


@needs_numpy2
def test_numpy1_script_runs_unmodified(tmp_path: Path) -> None:
    """`from numpy import mat, float_`, `np.product`, `np.NaN`, `np.in1d`, `np.trapz`,
    `np.alltrue`/`sometrue` and a star-imported `product`/`cumproduct` in its samplers: the
    script plans (the first slot is rejected by its test) and prints its own values."""
    script = write_shelf(tmp_path / "shelf")
    done = run([str(script)], cwd=tmp_path, cli=True)
    assert done.returncode == 0, done.stderr
    assert PLAN_LINE in done.stdout.splitlines()
    assert ("Slot: [1.5, 2.5, 3.0] volume: 11.25 dtype: float64 area: 3.0 mat: matrix"
            in done.stdout.splitlines())
    assert done.stderr == ""


@needs_numpy2
@pytest.mark.parametrize("cli", [True, False], ids=["ltamp-pddlstream-run", "python-m"])
def test_no_numpy_compat_leaves_numpy_as_installed(tmp_path: Path, cli: bool) -> None:
    script = write_shelf(tmp_path / "shelf")
    done = run(["--no-numpy-compat", str(script)], cwd=tmp_path, cli=cli)
    assert done.returncode == 1
    lines = done.stderr.splitlines()
    assert lines[-2].startswith("ImportError: cannot import name 'mat' from 'numpy'")
    assert lines[-1].startswith(f"ltamp: the script {script} failed in its own code")


@needs_numpy2
def test_removed_name_without_exact_equivalent_stays_the_scripts_error(tmp_path: Path
                                                                      ) -> None:
    """`np.asfarray` has no exact NumPy 2 equivalent: NumPy's own AttributeError."""
    script = write_shelf(tmp_path / "shelf")
    done = run([str(script), "--asfarray"], cwd=tmp_path, cli=False)
    assert done.returncode == 1
    assert done.stderr.splitlines()[-2].startswith(
        "AttributeError: `np.asfarray` was removed in the NumPy 2.0 release.")


def test_nothing_patched_outside_the_runner(tmp_path: Path) -> None:
    """A fresh interpreter: importing ltamp_cli, the drop-in API, the runner, this layer and
    building the CLI, then solving with the drop-in API, leaves numpy's namespace and
    ``__all__`` as they were; a script run in-process by run_target sees the names, and
    after it returns numpy is as before."""
    script = write_shelf(tmp_path / "shelf")
    code = f"""
import sys, types
import numpy
before, exported = dict(vars(numpy)), numpy.__all__
import ltamp_cli, ltamp_cli.pddlstream, ltamp_cli.pddlstream.alias
import ltamp_cli.pddlstream.run, ltamp_cli.pddlstream.numpy_compat
from ltamp_cli.cli.app import build_app
build_app()
from ltamp_cli.pddlstream import PDDLProblem, solve
problem = PDDLProblem('''(define (domain d) (:predicates (P)) (:action a :parameters ()
    :effect (P)))''', {{}}, None, {{}}, [], ('P',))
assert solve(problem, verbose=False).plan is not None
def changed():
    # Importing a submodule (numpy.linalg, ...) binds it on numpy: that is not a patch.
    now = vars(numpy)
    return sorted([k for k in now.keys() - before.keys()
                   if not isinstance(now[k], types.ModuleType) and not k.startswith('__')]
                  + [k for k, v in before.items() if now.get(k) is not v]
                  + (['__all__'] if numpy.__all__ is not exported else []))
assert changed() == [], changed()
from ltamp_cli.pddlstream.run import run_target
assert run_target({str(script)!r}) == 0
assert changed() == [], changed()
print('untouched')
"""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=180, cwd=tmp_path,
                          env={"PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1",
                               "PATH": "/usr/bin:/bin", "XDG_CACHE_HOME": str(tmp_path)})
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[-1] == "untouched"
    if numpy_lacks("mat"):
        assert PLAN_LINE in done.stdout.splitlines()


def fake_numpy(**attributes: object) -> types.ModuleType:
    module = types.ModuleType("fake_numpy")
    module.__dict__.update(attributes)
    return module


def test_existing_attribute_is_never_replaced() -> None:
    mine, prod, cumprod = object(), object(), object()
    fake = fake_numpy(mat=mine, asmatrix=object(), prod=prod, cumprod=cumprod,
                      __all__=["prod"])
    with installed(fake) as compat:
        assert fake.mat is mine  # its own mat stays
        assert fake.product is prod and fake.cumproduct is cumprod
        # Equivalents this module lacks (float64, nan, isin, ...) are skipped, not faked.
        assert not hasattr(fake, "float_") and not hasattr(fake, "in1d")
        assert not hasattr(fake, "NaN")
        assert set(compat.added) >= {"product", "cumproduct"} and "mat" not in compat.added
        assert fake.__all__[:1] == ["prod"] and "product" in fake.__all__
    assert fake.mat is mine and not hasattr(fake, "product")
    assert fake.__all__ == ["prod"]


def test_a_name_the_script_rebinds_stays_and_getattr_names_count_as_present() -> None:
    """NumPy 2.0-2.3 serve deprecated names (in1d, trapz) through their module
    ``__getattr__``: present, so not added. A name the script rebinds after install is the
    script's and survives uninstall."""
    fake = fake_numpy(prod=object(), asmatrix=object(), isin=np.isin, asarray=np.asarray)

    def module_getattr(name: str) -> object:
        if name == "in1d":
            return "numpy's own in1d"
        raise AttributeError(name)

    fake.__getattr__ = module_getattr  # type: ignore[attr-defined]
    compat = numpy_compat.install(fake)
    assert "in1d" not in compat.added and fake.in1d == "numpy's own in1d"
    fake.product = rebound = object()
    numpy_compat.uninstall(compat)
    assert fake.product is rebound and "mat" not in vars(fake)


@needs_numpy2
def test_restored_names_are_numpy2_equivalents_exactly() -> None:
    exported = np.__all__
    lacking = {legacy.name for legacy in LEGACY if numpy_lacks(legacy.name)}
    with installed() as compat:
        assert set(compat.added) == lacking  # every missing legacy name, nothing else
        assert np.mat is np.asmatrix and np.product is np.prod
        assert np.cumproduct is np.cumprod and np.round_ is np.round
        assert np.sometrue is np.any and np.alltrue is np.all
        assert np.float_ is np.float64 and np.complex_ is np.complex128
        assert np.NaN is np.nan and np.Inf is np.inf and np.infty is np.inf
        assert -np.inf == np.NINF and str(np.NZERO) == "-0.0"
        assert np.DataSource is np.lib.npyio.DataSource
        # in1d: NumPy 1 flattened its first argument (a 1-D result); isin keeps the shape.
        grid = np.array([[1, 5], [3, 7]])
        assert np.in1d(grid, [3, 5]).tolist() == [False, True, True, False]
        assert np.in1d(grid, [3, 5], invert=True).tolist() == [True, False, False, True]
        assert np.msort(np.array([[3, 1], [2, 4]])).tolist() == [[2, 1], [3, 4]]
        if "trapz" in compat.added:
            assert np.trapz([0.0, 2.0, 2.0], dx=0.5) == 1.5
        for name in NOT_RESTORED:  # no exact equivalent: still NumPy's AttributeError
            assert numpy_lacks(name), name
        assert set(compat.added) <= set(np.__all__)
    assert np.__all__ is exported
    assert not any(hasattr(np, name) for name in lacking)


def test_restored_and_left_absent_lists_are_disjoint_and_unique() -> None:
    names = [legacy.name for legacy in LEGACY]
    assert len(names) == len(set(names))
    assert not set(names) & set(NOT_RESTORED)


def test_porting_doc_lists_every_name() -> None:
    """docs/porting-from-pddlstream.md names every restored and every left-absent name."""
    page = (REPO / "docs" / "porting-from-pddlstream.md").read_text(encoding="utf-8")
    section = page[page.index("### NumPy 1 names"):page.index("## Running PDDLStream's own")]
    for name in [legacy.name for legacy in LEGACY] + list(NOT_RESTORED):
        assert f"`{name}`" in section or f"`{name}(" in section, name
