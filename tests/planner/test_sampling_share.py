"""Adaptive's sampling share after a search (issue #19): three times larger while no
optimistic task had action costs, main's otherwise, never below one binding step."""

from ltamp_cli.planner.algorithms import skeletons
from ltamp_cli.planner.algorithms.skeletons import sampling_share


def test_the_share_is_larger_only_without_action_costs() -> None:
    evaluated = 170  # a kitchen_fluent search
    with_costs = sampling_share(evaluated, action_costs=True)
    without = sampling_share(evaluated, action_costs=False)
    assert with_costs == round(evaluated * skeletons.STEPS_PER_EVALUATION) == 17
    assert without == round(evaluated * skeletons.STEPS_PER_EVALUATION_WITHOUT_COSTS) == 51
    assert without > with_costs


def test_a_search_that_evaluated_nothing_still_gets_one_step() -> None:
    assert sampling_share(0, action_costs=True) == 1
    assert sampling_share(0, action_costs=False) == 1
    assert sampling_share(2, action_costs=True) == 1
