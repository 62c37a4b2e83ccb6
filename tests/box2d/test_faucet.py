"""The faucet fills a cup standing under it and nothing else."""

from __future__ import annotations

from ltamp_cli.backends.box2d.faucet import Faucet, FaucetSpec
from ltamp_cli.backends.box2d.kitchenware import CupSpec, add_cup
from ltamp_cli.backends.box2d.particles import inside_box
from ltamp_cli.backends.box2d.world import Kitchen


def _kitchen_with_faucet(cup_x: float) -> tuple[Kitchen, Faucet, object, CupSpec]:
    kitchen = Kitchen()
    lay = kitchen.layout
    spec = CupSpec(3.0, 3.0)
    cup = add_cup(kitchen, spec, (cup_x, lay.table_top, 0.0))
    faucet = Faucet(kitchen, FaucetSpec(lay.faucet_x, lay.table_top + 6.0, capacity=60))
    return kitchen, faucet, cup, spec


def test_faucet_fills_cup_under_it() -> None:
    kitchen, faucet, cup, spec = _kitchen_with_faucet(Kitchen().layout.faucet_x)
    kitchen.step(250)
    assert faucet.emitted == 60 == len(kitchen.particles)
    pos = kitchen.particle_positions()
    inner = spec.inner_width / 2
    assert inside_box(pos, cup, -inner, inner, 0.0, spec.height).all()


def test_faucet_is_off_without_a_cup() -> None:
    kitchen, faucet, _, _ = _kitchen_with_faucet(0.0)
    kitchen.step(100)
    assert faucet.emitted == 0 and kitchen.particle_positions().shape == (0, 2)
