"""What a fresh ``pip install ltamp[...]`` adds to a venv; how fast ``ltamp --help`` starts.

The install size is measured without downloading anything: the requirements of a
``pyproject.toml`` (``--pyproject``, default this repository's; pass another checkout's to
compare) are resolved transitively against the distributions installed in the running
environment, and the sizes of the files their ``RECORD`` lists are summed (same versions as
a fresh install would get here; pip itself and ltamp are not counted). Start-up is the best
of ``--repeat`` runs of ``python -m ltamp_cli --help`` with ``PYTHONPATH`` at the checkout.

Prints a table and writes JSON (``--out``, default ``bench/results/install_size.json``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
import tomllib
from importlib.metadata import Distribution, PackageNotFoundError, distribution
from pathlib import Path

from packaging.markers import default_environment
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUT = ROOT / "bench" / "results" / "install_size.json"


def installed_bytes(dist: Distribution) -> int:
    """Total size of the files a distribution installed (bytes)."""
    total = 0
    for item in dist.files or []:
        path = Path(str(item.locate()))
        if path.is_file():
            total += path.stat().st_size
    return total


def closure(requirements: list[str], extras: tuple[str, ...]) -> dict[str, Distribution]:
    """Every installed distribution the requirements need, transitively, by canonical name."""
    found: dict[str, Distribution] = {}
    pending = [(Requirement(text), extras) for text in requirements]
    while pending:
        requirement, active = pending.pop()
        environment = dict(default_environment())
        if requirement.marker is not None and not any(
                requirement.marker.evaluate({**environment, "extra": extra})
                for extra in (*active, "")):
            continue
        name = canonicalize_name(requirement.name)
        wanted = tuple(requirement.extras)
        if name in found and not wanted:
            continue
        try:
            dist = distribution(requirement.name)
        except PackageNotFoundError:
            print(f"not installed here, not counted: {requirement.name}", file=sys.stderr)
            continue
        found[name] = dist
        pending.extend((Requirement(text), wanted) for text in dist.requires or [])
    return found


def project_requirements(pyproject: Path, extras: tuple[str, ...]) -> list[str]:
    project = tomllib.loads(pyproject.read_text(encoding="utf-8"))["project"]
    optional = project.get("optional-dependencies", {})
    return list(project.get("dependencies", [])) + [
        text for extra in extras for text in optional.get(extra, [])]


def help_start_s(checkout: Path, repeat: int) -> float:
    env = dict(os.environ, PYTHONPATH=str(checkout))
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        subprocess.run([sys.executable, "-m", "ltamp_cli", "--help"], env=env, cwd=checkout,
                       capture_output=True, check=True)
        best = min(best, time.perf_counter() - start)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pyproject", type=Path, default=ROOT / "pyproject.toml")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    args = parser.parse_args()
    checkout = args.pyproject.resolve().parent
    rows = []
    for label, extras in (("required", ()), ("make setup (all extras)",
                                              ("dev", "pybullet", "sapien", "fd", "ray",
                                               "gpytorch"))):
        dists = closure(project_requirements(args.pyproject, extras), extras)
        dists.pop("ltamp", None)
        sizes = {name: installed_bytes(dist) for name, dist in dists.items()}
        rows.append({"install": label, "distributions": len(sizes),
                     "mb": round(sum(sizes.values()) / 1e6, 1),
                     "largest": sorted(sizes, key=sizes.get, reverse=True)[:6]})
    start = help_start_s(checkout, args.repeat)
    print(f"{'install':<26} {'dists':>5} {'MB':>8}  largest")
    for row in rows:
        print(f"{row['install']:<26} {row['distributions']:>5} {row['mb']:>8.1f}  "
              f"{', '.join(row['largest'])}")
    print(f"ltamp --help start-up (best of {args.repeat}): {start:.3f} s")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"pyproject": str(args.pyproject), "rows": rows,
                                    "help_start_s": start}, indent=2))


if __name__ == "__main__":
    main()
