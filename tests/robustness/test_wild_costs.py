"""Round 3: PDDL numbers from the wild. ``(increase (total-cost) nan)``, ``-5``, ``inf``,
``1e400`` (overflows to inf) or a 400-digit cost in a domain, and ``(= (f a) nan)`` or a
negative value in a problem's init, were read by ``float`` and planned with: the search
answered "no plan" (exit 1) without a word, after 29 s wall for ``-5`` on blocksworld. They
are now refused in one line at the number's ``file:line:column``."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from ltamp_cli.pddlstream import InputError, solve_from_pddl

REPO = Path(__file__).resolve().parents[2]
DOMAIN = (REPO / "domains/blocksworld/domain.pddl").read_text()
PROBLEM = (REPO / "domains/blocksworld/blocks8.pddl").read_text()
FIRST_COST = "(increase (total-cost) 1)))\n  (:action put-down"


def with_cost(text: str) -> str:
    assert FIRST_COST in DOMAIN
    return DOMAIN.replace(FIRST_COST, FIRST_COST.replace(" 1)))", f" {text})))"), 1)


@pytest.mark.parametrize("cost", ["nan", "-5", "inf", "-inf", "1e400", "9" * 400, "NaN"])
def test_bad_action_cost_is_refused_at_its_position(cost: str) -> None:
    with pytest.raises(InputError, match=r"domain\.pddl:12:\d+: an action cost") as error:
        solve_from_pddl(with_cost(cost), PROBLEM, max_time=20)
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("cost", ["0", "-0", "2.5", "1e-300"])
def test_good_action_costs_still_plan(cost: str) -> None:
    plan, total = solve_from_pddl(with_cost(cost), PROBLEM, max_time=60)
    assert plan is not None and len(plan) >= 14 and total >= 0


@pytest.mark.parametrize("value", ["nan", "-1", "inf"])
def test_bad_function_value_in_init_is_refused(value: str) -> None:
    domain = DOMAIN.replace("(increase (total-cost) 1)))\n  (:action put-down",
                            "(increase (total-cost) (weight ?x))))\n  (:action put-down", 1)
    domain = domain.replace("(:functions (total-cost) - number)",
                            "(:functions (total-cost) - number (weight ?x - block) - number)")
    problem = PROBLEM.replace("(:init (handempty)",
                              f"(:init (handempty) (= (weight a) {value})")
    with pytest.raises(InputError, match="function value") as error:
        solve_from_pddl(domain, problem, max_time=20)
    assert "\n" not in str(error.value)


def test_cli_refuses_a_nan_cost_in_one_line(tmp_path: Path) -> None:
    (tmp_path / "domain.pddl").write_text(with_cost("nan"))
    (tmp_path / "problem.pddl").write_text(PROBLEM)
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    run = subprocess.run([sys.executable, "-m", "ltamp_cli", "solve",
                          str(tmp_path / "problem.pddl"), "--domain", str(tmp_path)],
                         capture_output=True, text=True, timeout=300, env=env)
    assert run.returncode == 2, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "domain.pddl:12:" in lines[0] and "nan" in lines[0], lines
