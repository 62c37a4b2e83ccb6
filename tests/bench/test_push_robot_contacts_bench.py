"""bench/push_robot_contacts.py: who touches the block in a Panda push trial (real trials)."""

from __future__ import annotations

import json
from pathlib import Path

from bench import push_robot_contacts
from ltamp_cli.backends.pybullet.skills.robot import RobotTrialPhysics

#: Two inputs of the committed 3D push fidelity row (goal parameterisation) with their free
#: and robot (setup 3) scores: a centred push the pad carries out (1), and a far off-centre
#: low push of a tall block (14: the free pad turns the block 1.1 rad; with the hand held
#: straight down, robot setup 2, the palm met the block first and pushed it straight, a
#: robot-only success; leaning back, the palm meets the block only once the pad has turned
#: it, and that touch is a collision).
INPUTS = {
    1: ([0.054604406729793144, 0.14219811182809183, 0.6145540757698547, 0.23543091061357352],
        [0.44633943924420555, 0.3827443876024802, -0.00010418631235298292, 0.12756858745472266],
        -1.0, -1.0),
    14: ([0.06725497847336141, 0.2608568396602843, 0.5461308180310691, 0.1843387468721489],
         [0.3839024756260731, 0.037494239113559424, 0.46421155172160555, 0.15680306982237477],
         -1.0, -1.0),
}


def _cache(path: Path) -> None:
    lines = []
    for seed, (context, control, free, robot) in INPUTS.items():
        for setting, score in (("pybullet", free), ("pybullet-panda", robot)):
            lines.append(json.dumps({
                "key": f"{push_robot_contacts.setting_name(setting)}|push|{seed}|{context}"
                       f"{control}", "setting": setting,
                "skill": "push", "seed": seed, "context": context, "control": control,
                "score": score, "valid": True, "error": None, "cpu_s": 0.1}))
    path.write_text("\n".join(lines) + "\n")


def test_the_palm_touches_the_turned_block_of_a_far_off_centre_low_push(tmp_path: Path) -> None:
    cache, out = tmp_path / "trials.jsonl", tmp_path / "contacts.json"
    _cache(cache)
    check = RobotTrialPhysics._check
    assert push_robot_contacts.main(["--cache", str(cache), "--inputs", "20",
                                     "--out", str(out)]) == 0
    assert RobotTrialPhysics._check is check  # the counting wrapper is removed
    report = json.loads(out.read_text())
    assert report["inputs"] == 2 and report["reproduced"] == 2
    touchers = {row[0]: row[1] for row in report["per_input"]}
    assert set(touchers[1]) == {"pad"}
    assert {"hand", "pad"} <= set(touchers[14])
    assert report["failures"] == {"collision": 1}
    assert report["pad_only"]["inputs"] == 1 and report["all"]["agreement"] == 1.0
    assert report["disagreements"] == []
    # Setup 2's straight-down hand: the palm, not the pad, touches the block first.
    assert push_robot_contacts.main(["--cache", str(cache), "--inputs", "20", "--out",
                                     str(out), "--push-pitch", "0"]) == 0
    touchers = {row[0]: row[1] for row in json.loads(out.read_text())["per_input"]}
    assert set(touchers[14]) == {"hand"}
