"""Fuzz ``ltamp`` with many more cases than the test suite (same strategies).

Mutates the shipped PDDL, stream and YAML problem files and CLI arguments (see
``tests/fuzz/ltamp_fuzz.py``), runs the CLI and counts outcomes: exit 0/1, exit 2 with one
stderr line, and failures (tracebacks, multi-line errors, escaping exceptions, time-outs,
writes outside the case folder, payloads that ran). Prints a table and writes JSON (after
every kind, so a long run that is stopped keeps what it measured).

    python bench/fuzz.py [--cases 10000] [--seed 0] [--out bench/results/fuzz.json]

Cases: the fixed hostile corpus (``tests/fuzz/hostile_corpus.py``, subprocesses), then
1 % (at least 20) mutated problems solved in ``ltamp`` subprocesses with a time limit, and
in-process: 40 % mutated PDDL files and 30 % YAML problems through ``check``, 15 % mutated
files through ``solve`` (0.5 s limit), the rest CLI argument lists.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import traceback
import warnings
from collections import Counter
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DEFAULT_OUT = REPO / "bench" / "results" / "fuzz.json"
SUBPROCESS_TIMEOUT_S = 120.0


def run(cases: int, seed: int, out: Path | None = None) -> dict[str, object]:
    sys.path.insert(0, str(REPO / "tests" / "fuzz"))
    import tempfile

    from hostile_corpus import CORPUS, run_case, solve_mutation
    from hypothesis import HealthCheck, Phase, given, settings
    from hypothesis import seed as hypothesis_seed
    from hypothesis import strategies as st
    from ltamp_fuzz import (
        PDDL_TARGETS,
        YAML_TARGETS,
        acceptable,
        cli_arguments,
        mutated_text,
        run_cli,
        run_mutated,
        sandbox,
    )

    counts: dict[str, Counter[str]] = {}
    failures: list[dict[str, object]] = []
    timings: dict[str, float] = {}

    def record(kind: str, outcome: object, where: object, problem: str | None = None) -> None:
        problem = problem or acceptable(outcome)  # type: ignore[arg-type]
        label = f"exit {outcome.code}" if problem is None else "FAIL"  # type: ignore[attr-defined]
        counts.setdefault(kind, Counter())[label] += 1
        if problem is not None and len(failures) < 20:
            failures.append({"kind": kind, "why": problem, "where": repr(where)[:300],
                             "stderr": outcome.stderr[-600:]})  # type: ignore[attr-defined]

    def report() -> dict[str, object]:
        return {"cases": cases, "seed": seed,
                "counts": {k: dict(sorted(v.items())) for k, v in counts.items()},
                "seconds": {k: round(v, 2) for k, v in timings.items()}, "failures": failures}

    with sandbox() as root:
        def fuzz_corpus() -> None:
            for hostile in CORPUS:
                with tempfile.TemporaryDirectory(dir=root) as workdir:
                    outcome, why = run_case(hostile, Path(workdir), root / "domains",
                                            SUBPROCESS_TIMEOUT_S)
                record("corpus", outcome, hostile.name, why)

        def fuzz_subprocess() -> None:
            @hypothesis_seed(seed)
            @settings(max_examples=share["subproc"], deadline=None, database=None,
                      phases=[Phase.generate], suppress_health_check=list(HealthCheck))
            @given(data=st.data())
            def case(data: st.DataObject) -> None:
                target = data.draw(st.sampled_from(PDDL_TARGETS + YAML_TARGETS))
                text = data.draw(mutated_text((root / target.file).read_text()))
                outcome, why = solve_mutation(root, target.file, target.problem, text,
                                              SUBPROCESS_TIMEOUT_S)
                record("subproc", outcome, target.file, why)

            case()

        def fuzz_files(kind: str, targets: list,  # type: ignore[type-arg]
                       command: str = "check") -> None:
            @hypothesis_seed(seed)
            @settings(max_examples=share[kind], deadline=None, database=None,
                      phases=[Phase.generate],
                      suppress_health_check=list(HealthCheck))
            @given(data=st.data())
            def case(data: st.DataObject) -> None:
                target = data.draw(st.sampled_from(targets))
                text = data.draw(mutated_text((root / target.file).read_text()))
                try:
                    record(kind, run_mutated(root, target, text, command=command), target.file)
                except Exception:  # an exception escaping main() is a finding, not a stop
                    counts.setdefault(kind, Counter())["FAIL"] += 1
                    failures.append({"kind": kind, "why": traceback.format_exc(limit=3)})

            case()

        def fuzz_cli() -> None:
            @hypothesis_seed(seed)
            @settings(max_examples=share["cli"], deadline=None, database=None,
                      phases=[Phase.generate],
                      suppress_health_check=list(HealthCheck))
            @given(args=cli_arguments(str(root)))
            def case(args: list[str]) -> None:
                try:
                    record("cli", run_cli(args), args)
                except Exception:
                    counts.setdefault("cli", Counter())["FAIL"] += 1
                    failures.append({"kind": "cli", "why": traceback.format_exc(limit=3)})

            case()

        share = {"subproc": max(20, cases // 100), "pddl": cases * 40 // 100,
                 "yaml": cases * 30 // 100, "solve": cases * 15 // 100}
        share["cli"] = max(0, cases - sum(share.values()))
        for kind, job in (("corpus", fuzz_corpus), ("subproc", fuzz_subprocess),
                          ("pddl", lambda: fuzz_files("pddl", PDDL_TARGETS)),
                          ("yaml", lambda: fuzz_files("yaml", YAML_TARGETS)),
                          ("solve", lambda: fuzz_files("solve", PDDL_TARGETS + YAML_TARGETS,
                                                       "solve")),
                          ("cli", fuzz_cli)):
            start = time.perf_counter()
            job()
            timings[kind] = time.perf_counter() - start
            print(f"{kind}: {dict(counts.get(kind, {}))} in {timings[kind]:.0f} s", flush=True)
            if out is not None:
                out.parent.mkdir(parents=True, exist_ok=True)
                out.write_text(json.dumps(report(), indent=2) + "\n")
    return report()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=10_000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    options = parser.parse_args()
    warnings.simplefilter("ignore")  # library deprecation warnings would pollute stderr
    report = run(options.cases, options.seed, options.out)
    print(f"{'kind':<8} {'cases':>7} {'exit 0':>7} {'exit 1':>7} {'exit 2':>7} {'FAIL':>5} "
          f"{'time s':>7}")
    for kind, counter in report["counts"].items():  # type: ignore[union-attr]
        total = sum(counter.values())
        print(f"{kind:<8} {total:>7} {counter.get('exit 0', 0):>7} {counter.get('exit 1', 0):>7} "
              f"{counter.get('exit 2', 0):>7} {counter.get('FAIL', 0):>5} "
              f"{report['seconds'][kind]:>7}")  # type: ignore[index]
    for failure in report["failures"]:  # type: ignore[union-attr]
        print("FAIL:", json.dumps(failure)[:400])
    options.out.parent.mkdir(parents=True, exist_ok=True)
    options.out.write_text(json.dumps(report, indent=2) + "\n")
    print(f"wrote {options.out}")


if __name__ == "__main__":
    main()
