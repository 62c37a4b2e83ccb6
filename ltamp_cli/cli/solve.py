"""``ltamp solve``: plan for a YAML (or PDDL) problem and print the plan."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from ltamp_cli.cli.paths import writable_output_file
from ltamp_cli.errors import InputError
from ltamp_cli.seeds import usable_seed

# Streams listed (slowest first) under "why no plan".
TIME_SPENT_STREAMS_SHOWN = 5


def register(app: typer.Typer) -> None:
    app.command("solve")(solve_command)


def solve_command(
    problem: Annotated[Path, typer.Argument(
        help="Problem file (.yaml, or .pddl with --domain), or a built-in name such as "
        "kitchen2d/coffee (see `ltamp problems`).")],
    algorithm: Annotated[str | None, typer.Option(
        help="adaptive | binding | focused | incremental (default: the problem's, else "
        "adaptive).")] = None,
    max_time: Annotated[float | None, typer.Option(
        "--max-time", help="Time limit in seconds (default: the problem's, else 60).")] = None,
    seed: Annotated[int | None, typer.Option(help="Seed for the stream samplers.")] = None,
    search: Annotated[str | None, typer.Option(
        help="Discrete search: ff (default) | lazy-greedy | wastar | fd | fd-wastar.")] = None,
    domain: Annotated[Path | None, typer.Option(
        help="Domain folder, for a .pddl problem file.")] = None,
    unit_costs: Annotated[bool, typer.Option(
        "--unit-costs", help="Ignore action costs while searching.")] = False,
    success_cost: Annotated[float | None, typer.Option(
        "--success-cost", help="Anytime: keep improving until the plan costs at most this "
        "(0: until --max-time).")] = None,
    skeleton: Annotated[list[str] | None, typer.Option(
        "--skeleton", help="An action pattern the plan must follow, in order (repeat the "
        "option): 'NAME ARG ...' with '?' for any argument, '*' any action, '...' any "
        "actions.")] = None,
    statistics: Annotated[bool, typer.Option(
        "--stats/--no-stats", help="Persist stream statistics per domain in the user cache "
        "directory.")] = True,
    json_output: Annotated[bool, typer.Option("--json", help="Print one JSON object.")] = False,
    backend: Annotated[str | None, typer.Option(
        "--backend", help="Execute the plan in this backend's simulator (e.g. box2d).")] = None,
    render: Annotated[Path | None, typer.Option(
        "--render", help="With --backend: write the execution as a GIF.")] = None,
    fps: Annotated[float | None, typer.Option(
        "--fps", help="With --render: GIF frames per second (at most 50; default 10).")] = None,
    speed: Annotated[float | None, typer.Option(
        "--speed", help="With --render: simulated seconds per GIF second (frames are "
        "skipped, the physics is unchanged; default: real time, faster when the GIF would "
        "last over 45 s).")] = None,
) -> None:
    """Solve PROBLEM; exit 0 when solved, 1 when infeasible or out of time, 2 on bad input."""
    from ltamp_cli.cli.conventions import progress_line
    from ltamp_cli.planner.algorithms.common import PlannerConfig, StreamError
    from ltamp_cli.planner.api import solve
    from ltamp_cli.planner.problem import load_problem
    from ltamp_cli.threads import use_one_thread

    if max_time is not None and not max_time > 0:  # also NaN
        raise InputError(f"--max-time: expected a positive number of seconds, got {max_time}")
    loaded = load_problem(problem, domain)
    use_one_thread()  # after loading the bindings: learned streams bring torch and scipy
    options = dict(loaded.planner_options)
    known = {"algorithm", "max_time", "seed", "search", "unit_costs", "initial_complexity",
             "max_complexity", "success_cost", "skeleton", "skeletons", "max_cost",
             "eager_cheap_streams",
             "incremental_grounding"}
    for key in options:
        if key not in known:
            raise InputError(f"{problem}: unknown planner option {key!r}: expected one of "
                             f"{', '.join(sorted(known))}")
    if algorithm is not None:
        options["algorithm"] = algorithm
    if max_time is not None:
        options["max_time"] = max_time
    if seed is not None:
        options["seed"] = usable_seed(seed)
    if search is not None:
        options["search"] = search
    if unit_costs:
        options["unit_costs"] = True
    if success_cost is not None:
        options["success_cost"] = success_cost
    if skeleton:
        options["skeleton"] = skeleton
        options.pop("skeletons", None)  # the command line's skeleton replaces the file's
    if "skeleton" in options:
        if not isinstance(options["skeleton"], list | tuple):
            raise InputError(f"{problem}: planner option 'skeleton' must be a list of action "
                             "patterns")
        options["skeleton"] = tuple(str(entry) for entry in options["skeleton"])
    if "skeletons" in options:
        skeletons = options["skeletons"]
        if not isinstance(skeletons, list | tuple) or not all(
                isinstance(entries, list | tuple) for entries in skeletons):
            raise InputError(f"{problem}: planner option 'skeletons' must be a list of "
                             "skeletons, each a list of action patterns")
        options["skeletons"] = tuple(tuple(str(e) for e in entries) for entries in skeletons)
    if statistics:
        from ltamp_cli.planner.statistics import default_statistics_dir

        options["statistics_dir"] = str(default_statistics_dir())
    timing = _gif_timing(fps, speed, render)  # bad values fail before planning
    try:
        config = PlannerConfig(**options)
        with progress_line(f"solving {loaded.name}"):
            result = solve(loaded, config)
    except StreamError as error:
        raise InputError(f"{loaded.bindings_source}: {error}") from None
    except TypeError as error:
        raise InputError(f"{problem}: bad planner options: {error}") from None
    if render is not None and backend is None:
        raise InputError("--render: needs --backend NAME to execute the plan")
    if render is not None:
        writable_output_file(render, "--render")
    report = None
    if backend is not None and result.solved:
        from ltamp_cli.backends.execution import execute_plan

        label = f"executing {len(result.plan or [])} actions on {backend}"
        with progress_line(label + (f", rendering {render}" if render else "")):
            report = execute_plan(backend, loaded, result, usable_seed(config.seed), render,
                                  timing)
    if json_output:
        if report is None:
            print(result.to_json())
        else:
            import json

            payload = json.loads(result.to_json())
            payload.update(executed=report.success, goal_holds=report.goal_holds,
                           execution=report.details)
            print(json.dumps(payload))
    else:
        _print_human(result)
        if report is not None:
            print(f"executed: {report.success}  goal_holds: {report.goal_holds}"
                  + (f"  ({report.details['error']})" if "error" in report.details else ""))
    if not result.solved or (report is not None and not (report.success and report.goal_holds)):
        raise typer.Exit(1)


def _gif_timing(fps: float | None, speed: float | None, render: Path | None):  # type: ignore[no-untyped-def]
    """The GIF timing of ``--fps``/``--speed`` (``None``: the executor's default)."""
    if fps is None and speed is None:
        return None
    if render is None:
        raise InputError(f"{'--fps' if fps is not None else '--speed'}: needs --render PATH")
    from ltamp_cli.backends.frames import MIN_FRAME_MS, GifTiming

    if fps is not None and not 0 < fps <= 1000 / MIN_FRAME_MS:
        raise InputError(f"--fps: expected a number in (0, {1000 // MIN_FRAME_MS}], got {fps:g}")
    if speed is not None and not speed > 0:
        raise InputError(f"--speed: expected a positive number, got {speed:g}")
    return GifTiming(**({"fps": fps} if fps is not None else {}), speed=speed)


def _print_human(result) -> None:  # type: ignore[no-untyped-def]
    out = sys.stdout
    if result.plan is None:
        print(f"status: {result.status} after {result.time_s:.3f} s", file=out)
        _print_diagnostics(result.diagnostics)
        return
    print(f"status: {result.status}  actions: {len(result.plan)}  cost: {result.cost:g}  "
          f"time: {result.time_s:.3f} s", file=out)
    width = len(str(len(result.plan)))
    for number, step in enumerate(result.plan, start=1):
        values = " ".join(_short(v) for v in step.values)
        print(f"{number:>{width}}. {step.name} {values}", file=out)


def _print_diagnostics(diagnostics: dict) -> None:  # type: ignore[type-arg]
    """Why no plan: what could never be reached, which streams never helped, what was tried."""
    if not diagnostics:
        return
    print("why no plan:")
    unreachable = diagnostics.get("unreachable_goal_facts") or []
    if unreachable:
        print("  goal facts unreachable even optimistically: " + " ".join(unreachable))
    for key, label in (("streams_never_called", "streams never called"),
                       ("streams_never_succeeded", "streams that never succeeded")):
        if diagnostics.get(key):
            print(f"  {label}: {', '.join(diagnostics[key])}")
    for number, skeleton in enumerate(diagnostics.get("last_skeletons") or [], start=1):
        print(f"  skeleton tried #{number}: {' '.join(skeleton)}")
    if diagnostics.get("stopped_in"):
        print(f"  stopped while in {diagnostics['stopped_in']}")
    spent = diagnostics.get("time_spent")
    if spent:
        print(f"  time: grounding {spent['grounding_s']:.3f} s, search {spent['search_s']:.3f} s "
              f"({spent['searches']} searches), streams {spent['streams_s']:.3f} s")
        for name, stream in list(spent["per_stream"].items())[:TIME_SPENT_STREAMS_SHOWN]:
            print(f"    {name}: {stream['calls']} calls, {stream['successes']} successes, "
                  f"{stream['seconds']:.3f} s")


def _short(value) -> str:  # type: ignore[no-untyped-def]
    from ltamp_cli.planner.result import to_jsonable

    value = to_jsonable(value)
    if isinstance(value, list):
        flat = [_short(v) for v in value]
        text = "[" + ", ".join(flat) + "]"
        return text if len(text) <= 40 else text[:37] + "...]"
    if isinstance(value, float):
        return f"{value:.3g}"
    return str(value)
