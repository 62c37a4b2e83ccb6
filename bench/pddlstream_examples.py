"""PDDLStream's own examples, run unmodified with ``ltamp_cli.pddlstream`` in its place.

Given a PDDLStream checkout, every ``examples/**/run.py`` (and the other example scripts
that call ``solve``) is imported from that checkout with its own primitives and samplers,
and its ``main()`` is run; only the ``pddlstream.*`` imports are redirected, by an import
hook, to :mod:`ltamp_cli.pddlstream` (general helpers of ``pddlstream.utils`` that are not
part of the planner's API, such as ``Profiler`` or ``safe_zip``, come from the checkout's
own ``pddlstream/utils.py``). The hook's ``solve`` converts the problem (load: parsing and
checking the example's unmodified ``domain.pddl``/``stream.pddl``), then solves it with
``adaptive`` whatever algorithm the example asks for. Examples that need modules not
installed here (pybullet, tkinter viewers, ...) or PDDLStream internals outside its public
API are reported as not loaded, with the reason.

    .venv/bin/python bench/pddlstream_examples.py PATH/TO/pddlstream [--max-time 60]
        [--only continuous_tamp,advanced/wild] [--example-args '-n 4 -p blocked']
        [--out bench/results/pddlstream_examples.json]

Without a checkout at PATH it prints why and exits 0 (never part of the tests or CI).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.abc
import importlib.machinery
import importlib.util
import io
import json
import sys
import time
import types
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import ltamp_cli.pddlstream as api
from ltamp_cli.errors import InputError
from ltamp_cli.pddlstream.problem import to_planning_problem
from ltamp_cli.pddlstream.satisfaction import assignment_from_solution, compile_satisfaction
from ltamp_cli.pddlstream.solve import to_solution
from ltamp_cli.planner.algorithms.common import PlannerConfig
from ltamp_cli.planner.api import solve as plan

REPO = Path(__file__).resolve().parent.parent
DEFAULT_OUT = REPO / "bench" / "results" / "pddlstream_examples.json"
SKIPPED_DIRS = ("retired", "todo", "pybullet")
# PDDLStream's solvers: whatever algorithm an example calls, the bench solves with adaptive.
SOLVERS = ("solve", "solve_adaptive", "solve_binding", "solve_focused", "solve_incremental")
SATISFIERS = ("constraint_satisfaction", "solve_pddlstream_satisfaction")


class Recorder:
    """What the redirected ``solve`` saw: load and solve times and the outcome."""

    def __init__(self, max_time: float) -> None:
        self.max_time = max_time
        self.runs: list[dict[str, Any]] = []

    def solve(self, problem: Any, stream_info: Any = None, **_: Any) -> api.Solution:
        start = time.perf_counter()
        cpu_start = time.process_time()
        record: dict[str, Any] = {"loaded": False, "solved": False}
        self.runs.append(record)
        try:
            planning_problem = to_planning_problem(problem, stream_info)
        except InputError as error:
            record["error"] = str(error)
            raise
        record["loaded"] = True
        record["load_s"] = time.perf_counter() - start
        config = PlannerConfig(algorithm="adaptive", max_time=self.max_time)
        result = plan(planning_problem, config)
        record.update(solved=result.solved, status=result.status, solve_s=result.time_s,
                      cpu_s=time.process_time() - cpu_start,
                      cost=result.cost if result.solved else None,
                      plan=[str(step) for step in result.plan or []])
        return to_solution(result)

    def satisfy(self, problem: Any, stream_info: Any = None, costs: bool = True,
                **_: Any) -> api.SatisfactionSolution:
        """PDDLStream's ``constraint_satisfaction``: compiled to planning, then solved as
        :meth:`solve` solves."""
        compiled = compile_satisfaction(problem, costs)
        solution = self.solve(compiled.problem, stream_info)
        return assignment_from_solution(compiled, solution.plan, solution.cost,
                                        solution.certificate)

    def solve_from_pddl(self, domain_pddl: str, problem_pddl: str, **_: Any) -> Any:
        start = time.perf_counter()
        cpu_start = time.process_time()
        record: dict[str, Any] = {"loaded": False, "solved": False}
        self.runs.append(record)
        found, cost = api.solve_from_pddl(domain_pddl, problem_pddl, max_time=self.max_time)
        record.update(loaded=True, load_s=0.0, solved=found is not None,
                      solve_s=time.perf_counter() - start,
                      cpu_s=time.process_time() - cpu_start, cost=cost,
                      plan=[str(step) for step in found or []])
        return found, cost


class Unsupported:
    """Stands for a ``pddlstream`` name that neither the API nor the checkout's helper
    modules provide (visualisation, FD internals, ...): importing it works, using it raises,
    so an example fails only if it really needs it before ``solve`` returns."""

    def __init__(self, name: str) -> None:
        self.name = name

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        raise NotImplementedError(f"{self.name} is not part of ltamp_cli.pddlstream")

    def __repr__(self) -> str:
        return f"<unsupported {self.name}>"


class PddlstreamRedirect(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Serves ``pddlstream`` and every ``pddlstream.*`` module as a view of the API."""

    def __init__(self, recorder: Recorder, checkout: Path) -> None:
        self.recorder = recorder
        self.checkout = checkout
        self.helpers: list[types.ModuleType] = []
        self.unsupported: set[str] = set()

    def find_spec(self, fullname: str, path: Sequence[str] | None, target: Any = None
                  ) -> importlib.machinery.ModuleSpec | None:
        if fullname != "pddlstream" and not fullname.startswith("pddlstream."):
            return None
        # Only the checkout's real modules: ``from pddlstream.x import NAME`` must not
        # import a submodule called NAME.
        where = self.checkout.joinpath(*fullname.split("."))
        if not (where.is_dir() or where.with_suffix(".py").is_file()):
            return None
        return importlib.machinery.ModuleSpec(fullname, self, is_package=True)

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> types.ModuleType:
        module = types.ModuleType(spec.name)
        module.__path__ = []  # a package: its submodules are served here too
        redirect = self

        def lookup(name: str) -> Any:
            if name.startswith("__"):
                raise AttributeError(name)
            if name in SOLVERS:
                return redirect.recorder.solve
            if name == "solve_from_pddl":
                return redirect.recorder.solve_from_pddl
            if name in SATISFIERS:
                return redirect.recorder.satisfy
            if hasattr(api, name):
                return getattr(api, name)
            for helpers in redirect.helpers:
                if hasattr(helpers, name) and not name.startswith("_"):
                    return getattr(helpers, name)
            redirect.unsupported.add(f"{spec.name}.{name}")
            return Unsupported(f"{spec.name}.{name}")

        module.__getattr__ = lookup  # type: ignore[method-assign]
        return module

    def exec_module(self, module: types.ModuleType) -> None:
        return None

    def load_helpers(self) -> None:
        """The checkout's general helper modules (tuple/formula utilities, no planner)."""
        for relative in ("pddlstream/utils.py", "pddlstream/language/constants.py"):
            path = self.checkout / relative
            name = "_pddlstream_checkout_" + path.stem
            spec = importlib.util.spec_from_file_location(name, path)
            if spec is None or spec.loader is None:
                continue
            module = importlib.util.module_from_spec(spec)
            try:
                spec.loader.exec_module(module)
            except Exception as error:  # a helper module that does not load is left out
                print(f"not using {relative}: {type(error).__name__}: {error}")
                continue
            self.helpers.append(module)


def example_scripts(checkout: Path) -> list[Path]:
    """Example scripts that call ``solve`` and define ``main``, outside skipped folders."""
    scripts = []
    for path in sorted((checkout / "examples").rglob("*.py")):
        relative = path.relative_to(checkout / "examples")
        if relative.parts[0] in SKIPPED_DIRS:
            continue
        text = path.read_text(errors="replace")
        if "def main(" in text and "solve" in text and "__main__" in text:
            scripts.append(path)
    return scripts


def module_name(checkout: Path, path: Path) -> str:
    return ".".join(path.relative_to(checkout).with_suffix("").parts)


def run_example(checkout: Path, path: Path, recorder: Recorder,
                example_args: Sequence[str] = ()) -> dict[str, Any]:
    """Import the example from the checkout and run its ``main()`` with ``example_args`` as
    its command line; summarise its first ``solve``."""
    name = module_name(checkout, path)
    row: dict[str, Any] = {"example": str(path.relative_to(checkout / "examples")),
                           "loaded": False, "solved": False}
    recorder.runs = []
    saved_argv = sys.argv
    sys.argv = [str(path), *example_args]
    output = io.StringIO()
    try:
        with contextlib.redirect_stdout(output):
            module = importlib.import_module(name)
            module.main()
    except (ImportError, AttributeError) as error:
        if not recorder.runs:
            row["error"] = f"{type(error).__name__}: {error}"
    except SystemExit:
        pass
    except Exception as error:
        if not recorder.runs or recorder.runs[0].get("solve_s") is None:
            row["error"] = f"{type(error).__name__}: {error}"
    finally:
        sys.argv = saved_argv
    if recorder.runs:
        first = recorder.runs[0]
        row.update({k: v for k, v in first.items() if k != "plan"})
        row["plan_length"] = len(first.get("plan", []))
        row["solves"] = len(recorder.runs)
    elif "error" not in row:
        row["error"] = "main() never called solve"
    return row


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("checkout", type=Path, help="a PDDLStream checkout (git clone)")
    parser.add_argument("--max-time", type=float, default=60.0)
    parser.add_argument("--only", default="", help="comma-separated example paths (prefixes)")
    parser.add_argument("--example-args", default="",
                        help="command line given to every example, e.g. '-n 4 -p blocked'")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    args = parser.parse_args()
    checkout = args.checkout.resolve()
    if not (checkout / "examples").is_dir():
        print(f"no PDDLStream checkout at {checkout} (no examples/ folder): skipped")
        return 0
    recorder = Recorder(args.max_time)
    redirect = PddlstreamRedirect(recorder, checkout)
    sys.meta_path.insert(0, redirect)
    redirect.load_helpers()
    sys.path.insert(0, str(checkout))
    only = [o for o in args.only.split(",") if o]
    rows = []
    for path in example_scripts(checkout):
        relative = str(path.relative_to(checkout / "examples"))
        if only and not any(relative.startswith(prefix) for prefix in only):
            continue
        redirect.unsupported.clear()
        rows.append(run_example(checkout, path, recorder, args.example_args.split()))
        row = rows[-1]
        row["unsupported_names"] = sorted(redirect.unsupported)
        print(f"{row['example']:<40} loaded={row['loaded']!s:<5} solved={row['solved']!s:<5} "
              f"load={row.get('load_s', float('nan')):.3f}s "
              f"solve={row.get('solve_s', float('nan')):.3f}s "
              f"cpu={row.get('cpu_s', float('nan')):.2f}s "
              f"{row.get('status', '')} {row.get('error', '')[:90]}",
              flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"checkout": str(checkout), "max_time": args.max_time,
                                    "examples": rows}, indent=2, default=str))
    print(f"{sum(r['loaded'] for r in rows)}/{len(rows)} loaded, "
          f"{sum(r['solved'] for r in rows)}/{len(rows)} solved; wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
