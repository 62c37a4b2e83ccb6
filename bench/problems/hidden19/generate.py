"""Writes the hidden suite's problem files (``*.yaml`` next to this file) from the layouts
below, so that block lists, initial facts and goals stay consistent; the YAML files are
committed and read by ``bench/planner_hidden.py``, ``ltamp solve`` and the tests.

    python bench/problems/hidden19/generate.py
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

HERE = Path(__file__).resolve().parent


@dataclass
class Layout:
    """One robots-domain problem: blocks ``{name: (x, width)}``, fixed obstacles the same,
    robots ``{name: (reach lo, reach hi, home x)}``, goals ``[(block, region)]``."""

    name: str
    comment: str
    regions: dict[str, tuple[float, float]]
    blocks: dict[str, tuple[float, float]]
    goals: list[tuple[str, str]]
    robots: dict[str, tuple[float, float, float]] = field(
        default_factory=lambda: {"r1": (-30.0, 30.0, -5.0)})
    obstacles: dict[str, tuple[float, float]] = field(default_factory=dict)
    planner: dict[str, Any] = field(default_factory=dict)


def robots_problem(layout: Layout) -> tuple[str, dict[str, Any]]:
    objects: dict[str, Any] = {}
    init: list[str] = []
    for robot, (_, _, home) in layout.robots.items():
        objects[robot] = None
        objects[f"q_{robot}"] = [home, 6.0]
        init += [f"(Robot {robot})", f"(Conf {robot} q_{robot})",
                 f"(AtConf {robot} q_{robot})", f"(HandEmpty {robot})", f"(CanMove {robot})"]
    for region in layout.regions:
        objects[region] = None
        init.append(f"(Region {region})")
    for block, (x, _) in {**layout.blocks, **layout.obstacles}.items():
        objects[block] = None
        objects[f"p_{block}"] = x
        init += [f"(Block {block})", f"(Pose {block} p_{block})", f"(AtPose {block} p_{block})"]
        if block in layout.blocks:
            init.append(f"(Movable {block})")
    goal = " ".join(f"(In {block} {region})" for block, region in layout.goals)
    goal += " " + " ".join(f"(HandEmpty {robot})" for robot in layout.robots)
    world = {
        "regions": {k: list(v) for k, v in layout.regions.items()},
        "robots": {k: [lo, hi] for k, (lo, hi, _) in layout.robots.items()},
        "blocks": {k: {"width": w, "height": 2.0}
                   for k, (_, w) in {**layout.blocks, **layout.obstacles}.items()},
        "carry_height": 5.0,
    }
    doc = {"name": layout.name.replace("_", "-"), "domain": "robots",
           "bindings": "robots/streams.py", "world": world, "objects": objects,
           "init": init, "goal": f"(and {goal})",
           "planner": {"max_time": 60, **layout.planner}}
    return layout.comment, doc


def stack_problem(name: str, comment: str, regions: dict[str, tuple[float, float]],
                  towers: list[tuple[str, float, list[tuple[str, float, float]]]],
                  goal: str) -> tuple[str, dict[str, Any]]:
    """``towers``: ``(region, x, [(block, width, height) bottom first])``."""
    objects: dict[str, Any] = {"q0": [0.0, 10.0]}
    init = ["(Conf q0)", "(AtConf q0)", "(HandEmpty)", "(CanMove)"]
    blocks: dict[str, dict[str, float]] = {}
    for region in regions:
        objects[region] = None
        init.append(f"(Region {region})")
    for region, x, column in towers:
        y, below = 0.0, None
        for block, w, h in column:
            objects[block] = None
            objects[f"p_{block}"] = [x, y]
            blocks[block] = {"width": w, "height": h}
            init += [f"(Block {block})", f"(Pose {block} p_{block})",
                     f"(AtPose {block} p_{block})"]
            if below is None:
                init.append(f"(Contained {block} p_{block} {region})")
            else:
                init.append(f"(Supports {block} p_{block} {below} p_{below})")
            y, below = y + h, block
    world = {"regions": {k: list(v) for k, v in regions.items()}, "blocks": blocks,
             "carry_height": 12.0}
    doc = {"name": name.replace("_", "-"), "domain": "stack", "bindings": "stack/streams.py",
           "world": world, "objects": objects, "init": init,
           "goal": f"(and {goal} (HandEmpty))", "planner": {"max_time": 60}}
    return comment, doc


TABLE = {"table": (-20.0, 20.0)}


def layouts() -> list[tuple[str, tuple[str, dict[str, Any]]]]:
    regions3 = Layout(
        "hidden_regions3_4",
        "Three goal regions, four blocks of widths 1-3 m; c sits in g1, where a and b can fit\n"
        "only once c has left for g2.",
        {**TABLE, "g1": (4.0, 8.0), "g2": (9.0, 13.0), "g3": (-19.0, -15.0)},
        {"a": (-8.0, 1.0), "b": (-4.0, 1.5), "c": (6.0, 2.0), "d": (0.0, 3.0)},
        [("a", "g1"), ("b", "g1"), ("c", "g2"), ("d", "g3")])
    chain = Layout(
        "hidden_chain_4",
        "A chain: b, c and d each sit in a 3 m region that fits one block; a must go to g1,\n"
        "b to g2, c to g3, so d, then c, then b must move out of the way first.",
        {**TABLE, "g1": (0.0, 3.0), "g2": (5.0, 8.0), "g3": (10.0, 13.0)},
        {"a": (-10.0, 2.0), "b": (1.5, 2.0), "c": (6.5, 2.0), "d": (11.5, 2.0)},
        [("a", "g1"), ("b", "g2"), ("c", "g3")])
    chosen = [
        regions3,
        Layout("hidden_obstacles_3",
               "A goal region [0, 9] with a fixed 1 m post at 4.5 (4 m free on either side):\n"
               "a (2 m), b (2 m) and c (1.5 m) must all fit in it; a second post stands on\n"
               "the table. Posts are blocks nobody can grasp.",
               {**TABLE, "goal": (0.0, 9.0)},
               {"a": (-6.0, 2.0), "b": (-12.0, 2.0), "c": (13.0, 1.5)},
               [("a", "goal"), ("b", "goal"), ("c", "goal")],
               obstacles={"post1": (4.5, 1.0), "post2": (-9.0, 1.0)}),
        chain,
        Layout("hidden_clutter_10",
               "Ten blocks of widths 1-2.5 m in a row; a, b, c must go to g1 (6 m) and d, e to\n"
               "g2 (6 m), where clutter blocks f and g sit.",
               {"table": (-30.0, 30.0), "g1": (20.0, 26.0), "g2": (-26.0, -20.0)},
               {"a": (-12.0, 1.5), "b": (-8.0, 1.5), "c": (-4.0, 1.0), "d": (0.0, 2.0),
                "e": (4.0, 2.0), "f": (23.0, 2.5), "g": (-23.0, 2.0), "h": (8.0, 1.0),
                "i": (12.0, 2.0), "j": (16.0, 1.5)},
               [("a", "g1"), ("b", "g1"), ("c", "g1"), ("d", "g2"), ("e", "g2")]),
        Layout("hidden_clutter_12",
               "Twelve blocks; two in each of three goal regions (5 m, 5 m, 4 m) with a\n"
               "clutter block already in every goal region.",
               {"table": (-30.0, 30.0), "g1": (20.0, 25.0), "g2": (-25.0, -20.0),
                "g3": (-2.0, 2.0)},
               {"a": (-16.0, 1.5), "b": (-12.0, 1.5), "c": (-8.0, 1.0), "d": (-5.0, 2.0),
                "e": (5.0, 1.5), "f": (8.0, 1.0), "g": (22.5, 2.0), "h": (-22.5, 2.0),
                "i": (0.0, 2.0), "j": (11.0, 2.0), "k": (14.0, 1.5), "l": (17.0, 2.0)},
               [("a", "g1"), ("b", "g1"), ("c", "g2"), ("d", "g2"), ("e", "g3"),
                ("f", "g3")]),
        Layout("hidden_handoff_2",
               "Two robots: r1 reaches [-20, 2], r2 [-2, 20]; a and b start on r1's side and\n"
               "must end in the goal on r2's side, handed over through the middle.",
               {**TABLE, "middle": (-4.0, 4.0), "goal": (12.0, 18.0)},
               {"a": (-10.0, 2.0), "b": (-6.0, 2.0)},
               [("a", "goal"), ("b", "goal")],
               robots={"r1": (-20.0, 2.0, -12.0), "r2": (-2.0, 20.0, 12.0)}),
        Layout("hidden_robots2_4",
               "Two robots (r1 [-20, 3], r2 [-3, 20]); a, b go from left to right, c, d from\n"
               "right to left, through a shared middle region.",
               {**TABLE, "middle": (-5.0, 5.0), "left": (-19.0, -13.0), "right": (13.0, 19.0)},
               {"a": (-10.0, 2.0), "b": (-7.0, 1.5), "c": (8.0, 2.0), "d": (11.0, 1.5)},
               [("a", "right"), ("b", "right"), ("c", "left"), ("d", "left")],
               robots={"r1": (-20.0, 3.0, -12.0), "r2": (-3.0, 20.0, 12.0)}),
        Layout("hidden_regions3_4_unit", regions3.comment + "\nUnit costs.",
               regions3.regions, regions3.blocks, regions3.goals,
               planner={"unit_costs": True}),
        Layout("hidden_chain_4_unit", chain.comment + "\nUnit costs.",
               chain.regions, chain.blocks, chain.goals, planner={"unit_costs": True}),
    ]
    problems = [(layout.name, robots_problem(layout)) for layout in chosen]
    problems.append(("hidden_stack_3", stack_problem(
        "hidden_stack_3", "Reverse a tower: a on b on c at the table's centre; the goal is\n"
        "c on b on a with a in the goal region.",
        {"table": (-10.0, 10.0), "goal": (6.0, 10.0)},
        [("table", 0.0, [("c", 2.0, 2.0), ("b", 2.0, 2.0), ("a", 2.0, 2.0)])],
        "(On c b) (On b a) (In a goal)")))
    problems.append(("hidden_stack_4", stack_problem(
        "hidden_stack_4", "Build a tower of four blocks of widths 3, 2.5, 2 and 1.5 m in the\n"
        "goal region; the 3 m block starts under the 2 m one.",
        {"table": (-12.0, 12.0), "goal": (7.0, 11.0)},
        [("table", -6.0, [("d", 3.0, 1.5), ("b", 2.0, 2.0)]),
         ("table", 0.0, [("c", 2.5, 1.0)]), ("table", 4.0, [("a", 1.5, 1.5)])],
        "(On a b) (On b c) (On c d) (In d goal)")))
    return problems


def main() -> None:
    for name, (comment, doc) in layouts():
        header = "".join(f"# {line}\n" for line in comment.splitlines())
        header += "# Written by generate.py (issue #19's hidden suite); edit the layout there.\n"
        head = {k: v for k, v in doc.items() if k != "init"}
        tail = {"goal": head.pop("goal"), "planner": head.pop("planner")}
        text = (yaml.safe_dump(head, sort_keys=False, default_flow_style=None, width=96)
                + "init:\n" + "".join(f"  - {fact}\n" for fact in doc["init"])
                + yaml.safe_dump(tail, sort_keys=False, default_flow_style=None, width=96))
        (HERE / f"{name}.yaml").write_text(header + text)
        print(f"wrote {name}.yaml")


if __name__ == "__main__":
    main()
