"""bench/outcome_acq.py: online and pool-mode flick2d jobs share one setup and one record
(small sizes; the committed logs' jobs were rerun bit for bit at the standard sizes)."""

from __future__ import annotations

from bench import outcome_acq

SMALL = {"budget": 14, "init": 4, "eval_every": 7, "contexts": 6, "candidates": 200}


def test_online_and_pool_jobs_share_the_held_out_goals_and_the_record() -> None:
    online = outcome_acq.run_job("random", 3, sizes=dict(SMALL))
    assert online["skill"] == "flick2d" and online["sizes"] == SMALL
    assert [p["n_trials"] for p in online["curve"]] == [7, 14]
    assert len(online["replay_bound"]) == SMALL["contexts"]
    assert 0 <= online["moved"] <= SMALL["budget"]
    again = outcome_acq.run_job("random", 3, sizes=dict(SMALL))
    assert {k: v for k, v in again.items() if k != "cpu_s"} == {
        k: v for k, v in online.items() if k != "cpu_s"}

    pool = outcome_acq.flick_pool()[:60]
    pooled = outcome_acq.run_pool_job("pool-gp", 3, pool, sizes=dict(SMALL))
    assert pooled["skill"] == "flick2d-pool" and pooled["sizes"] == {**SMALL, "pool": 60}
    assert pooled["config"] == outcome_acq.POOL_VARIANTS["pool-gp"]
    assert [p["n_trials"] for p in pooled["curve"]] == [7, 14]
    assert len(pooled["replay_bound"]) == SMALL["contexts"]
    assert 0 <= pooled["training_successes"] <= SMALL["budget"]
