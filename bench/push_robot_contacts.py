"""What pushes the block in the Panda's push trials? A diagnosis of ``3d-push-robot``.

The fidelity bench's ``3d-push-robot`` row (:mod:`bench.fidelity`) compares the free-floating
fingertip pad with the Panda holding it. This reruns the row's robot trials (inputs and trial
seeds read from the fidelity cache, ``--cache``; inputs ``< --inputs``) and counts, per
trial, the simulated steps on which each robot body touches the block: the held pad, the
hand (link 8: the palm, which the push's grasp does not filter out, unlike the fingers) or
another arm link. Since robot push setup 3 an arm link touching the block ends the trial
as a ``"collision"`` (so a count of ``hand`` is its first contact), and the hand leans back
by ``RobotSettings.push_pitch`` (π/4; ``--push-pitch 0`` reruns setup 2's straight-down
grasp, whose palm pushed tall blocks: the trials then fail at the palm's first touch). A
trial is *pad-only* when nothing but the pad touched the block. The table gives the label
agreement of free vs robot (cached labels of the current setup's keys; a rerun's score
must reproduce its cached one) on pad-only inputs and on the others, with 95 % Wilson
intervals, and lists the disagreements with the toucher. Written to ``--out`` (default
``bench/results/push_robot_contacts.json``). About 0.2 s CPU per trial; the committed runs
(setup 2's is ``push_goal_robot_contacts.json``):

    OMP_NUM_THREADS=1 .venv/bin/python bench/push_robot_contacts.py \
        --cache docs/results/fidelity/push_goal_trials.jsonl --inputs 600 \
        --out docs/results/fidelity/push_goal_robot_contacts_setup3.json
"""

from __future__ import annotations

import argparse
import collections
import json
import platform
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pybullet as p

from bench.fidelity import RESULTS_DIR, is_success, load_cache, trial_key
from ltamp_cli.backends import load_backend
from ltamp_cli.backends.pybullet.robot.arm import PANDA_HAND_LINK
from ltamp_cli.backends.pybullet.skills import robot as robot_skill
from ltamp_cli.backends.pybullet.skills.robot import RobotSettings
from ltamp_cli.learning.metrics import wilson_interval

SKILL = "push"


@contextmanager
def contact_counting(counts: collections.Counter[str]) -> Iterator[None]:
    """While active, every robot trial step adds to ``counts`` the bodies touching a free
    body (the block): ``"pad"``, ``"hand"`` or ``"arm link <k>"`` (one count per step and
    toucher). Wraps :meth:`RobotTrialPhysics._check` (run after every step) and restores it."""
    original = robot_skill.RobotTrialPhysics._check

    def check(self: robot_skill.RobotTrialPhysics, step: int) -> None:
        arm, tool, client = self.state.arm, self.state.tool, self.world.client
        if arm is not None and tool is not None:
            touching: set[str] = set()
            for body in self.state.free:
                if p.getContactPoints(tool.body, body.body, physicsClientId=client):
                    touching.add("pad")
                for contact in p.getContactPoints(arm.body_id, body.body,
                                                  physicsClientId=client):
                    link = contact[3]
                    touching.add("hand" if link == PANDA_HAND_LINK else f"arm link {link}")
            counts.update(touching)
        original(self, step)

    robot_skill.RobotTrialPhysics._check = check  # type: ignore[method-assign]
    try:
        yield
    finally:
        robot_skill.RobotTrialPhysics._check = original  # type: ignore[method-assign]


def setting_name(setting: str) -> str:
    """The versioned name a push trial of ``setting`` has in the fidelity cache's keys now
    (e.g. ``pybullet-panda@v1.1r3``): records of older physics or robot setups are skipped."""
    return trial_key(setting, SKILL, np.zeros(0), np.zeros(0), 0).split("|")[0]


def cached_pairs(cache_path: Path, n_inputs: int) -> list[tuple[dict, dict]]:
    """(free ``pybullet``, robot ``pybullet-panda``) push records of inputs ``< n_inputs``
    (trial seed = input index for the fidelity bench's seed 0) of the current physics and
    robot setup versions, in input order."""
    names = {setting_name(setting): setting for setting in ("pybullet", "pybullet-panda")}
    by_seed: dict[int, dict[str, dict]] = collections.defaultdict(dict)
    for key, record in load_cache(cache_path).items():
        setting = names.get(key.split("|")[0])
        if record["skill"] == SKILL and setting is not None:
            by_seed[record["seed"]][setting] = record
    return [(pair["pybullet"], pair["pybullet-panda"]) for seed, pair in sorted(by_seed.items())
            if seed < n_inputs and len(pair) == 2]


def _agreement(pairs: list[tuple[dict, dict]]) -> dict:
    agree = sum(is_success(f) == is_success(r) for f, r in pairs)
    return {"inputs": len(pairs), "agree": agree,
            "agreement": agree / len(pairs) if pairs else None,
            "wilson95": list(wilson_interval(agree, len(pairs))) if pairs else None,
            "free_success": sum(is_success(f) for f, _ in pairs),
            "robot_success": sum(is_success(r) for _, r in pairs)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cache", type=Path, required=True, help="the fidelity trial cache")
    parser.add_argument("--inputs", type=int, default=200, help="inputs 0..N-1 of the row")
    parser.add_argument("--out", type=Path, default=RESULTS_DIR / "push_robot_contacts.json")
    parser.add_argument("--push-pitch", type=float, default=RobotSettings().push_pitch,
                        help="lean of the hand holding the pad (rad; 0: setup 2's grasp, "
                             "whose reruns then need not reproduce the cached scores)")
    args = parser.parse_args(argv)
    pairs = cached_pairs(args.cache, args.inputs)
    if not pairs:
        parser.error(f"--cache {args.cache}: no push input has both a free and a robot trial")
    backend = load_backend("pybullet", robot="panda",
                           robot_settings=RobotSettings(push_pitch=args.push_pitch))
    rows, cpu = [], 0.0
    try:
        for free, robot in pairs:
            counts: collections.Counter[str] = collections.Counter()
            start = time.process_time()
            with contact_counting(counts):
                result = backend.run_trial(SKILL, np.asarray(robot["context"]),
                                           np.asarray(robot["control"]), robot["seed"])
            cpu += time.process_time() - start
            rows.append({"input": robot["seed"], "touchers": dict(sorted(counts.items())),
                         "reproduced": float(result.score) == float(robot["score"]),
                         "reason": result.info.get("reason"),
                         "free": is_success(free), "robot": is_success(robot),
                         "free_outcome": free.get("outcome"), "robot_outcome": robot.get("outcome"),
                         "control": robot["control"], "context": robot["context"]})
    finally:
        backend.close()
    by_input = {r["input"]: r for r in rows}
    pad_only = [pair for pair in pairs if set(by_input[pair[1]["seed"]]["touchers"]) == {"pad"}]
    others = [pair for pair in pairs if set(by_input[pair[1]["seed"]]["touchers"]) != {"pad"}]
    toucher_sets = collections.Counter(
        "+".join(sorted(r["touchers"])) or "nothing" for r in rows)
    report = {
        "skill": SKILL, "cache": str(args.cache), "inputs": len(rows),
        "push_pitch": args.push_pitch, "robot_setup": setting_name("pybullet-panda"),
        "failures": dict(collections.Counter(r["reason"] for r in rows if r["reason"])),
        "reproduced": sum(r["reproduced"] for r in rows),
        "touchers": dict(sorted(toucher_sets.items())),
        "all": _agreement(pairs), "pad_only": _agreement(pad_only),
        "not_pad_only": _agreement(others),
        "disagreements": [r for r in rows if r["free"] != r["robot"]],
        # One line per input: index, steps touched per toucher, free and robot labels.
        "per_input": [[r["input"], r["touchers"], r["free"], r["robot"]] for r in rows],
        "cpu_s_per_trial": cpu / len(rows), "machine": platform.platform(),
    }
    print(f"{len(rows)} robot push trials rerun ({report['reproduced']} reproduce the cached "
          f"score); who touched the block: {report['touchers']}")
    for name in ("all", "pad_only", "not_pad_only"):
        a = report[name]
        if a["inputs"]:
            print(f"{name:<13} {a['agree']:>4}/{a['inputs']:<4} = {a['agreement']:.3f} "
                  f"[{a['wilson95'][0]:.3f}, {a['wilson95'][1]:.3f}]  free ok "
                  f"{a['free_success']}, robot ok {a['robot_success']}")
    for r in report["disagreements"]:
        print(f"  input {r['input']}: free {r['free']}, robot {r['robot']}, touched by "
              f"{r['touchers']}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    partial = args.out.with_suffix(".json.tmp")
    partial.write_text(json.dumps(report, indent=None) + "\n")
    partial.replace(args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
