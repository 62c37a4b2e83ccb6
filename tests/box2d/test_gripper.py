"""The gripper grasps by contact and carries what it holds."""

from __future__ import annotations

from ltamp_cli.backends.box2d.gripper import Gripper
from ltamp_cli.backends.box2d.kitchenware import CupSpec, add_cup
from ltamp_cli.backends.box2d.world import Kitchen


def test_close_grasps_cup_handle_and_lifts_it() -> None:
    kitchen = Kitchen()
    top = kitchen.layout.table_top
    spec = CupSpec(4.0, 4.0)
    cup = add_cup(kitchen, spec, (0.0, top, 0.0))
    kitchen.step(20)  # let the cup rest on the table
    gripper = Gripper(kitchen, (spec.handle_x, top + 2.0, 0.0), opening=0.7)
    assert gripper.close() == cup  # pybox2d wrappers compare by body, not identity
    assert 0.15 < gripper.opening < 0.25  # closed on the 0.2-wide handle bar
    gripper.move((spec.handle_x, top + 6.0, 0.0), speed=3.0)
    assert cup.position[1] > top + 3.9
    gripper.release()
    kitchen.step(200)
    assert abs(cup.position[1] - top) < 0.05  # fell back onto the table


def test_close_on_nothing_grasps_nothing() -> None:
    kitchen = Kitchen()
    gripper = Gripper(kitchen, (0.0, 30.0, 0.0), opening=0.7)
    assert gripper.close(max_time=1.0) is None
    assert gripper.held is None
