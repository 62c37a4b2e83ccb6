"""al2d's job log tells a push job that learns from outcomes from the score-only ones of
earlier runs, so a rerun does not resume the old jobs as if they were the new ones."""

from __future__ import annotations

import pytest

from bench.paper import al2d


def test_push_jobs_are_keyed_by_hindsight(monkeypatch: pytest.MonkeyPatch) -> None:
    own = {"budget": 100, "seeds": 5}
    assert al2d._job_key_sizes(own, "pour") == own  # no outcome: logged jobs stay valid
    assert al2d._job_key_sizes(own, "scoop") == own
    assert al2d._job_key_sizes(own, "push") == {**own, "hindsight": True}
    monkeypatch.setattr(al2d, "HINDSIGHT", False)
    assert al2d._job_key_sizes(own, "push") == own


def test_lse_push_jobs_name_their_acquisition() -> None:
    # A job of the earlier default acquisition ("lse/0") must not be resumed as this one.
    assert al2d.job_key("lse", 0, learns_from_outcome=True) == "lse+outcome-cover/0"
    assert al2d.job_key("lse", 3, learns_from_outcome=False) == "lse/3"
    assert al2d.job_key("nn-r", 1, learns_from_outcome=True) == "nn-r/1"
    # lse2 chooses by the outcome acquisition too (issue #21, third outcome session)
    assert al2d.job_key("lse2", 2, learns_from_outcome=True) == "lse2+outcome-cover/2"
    assert al2d.job_key("lse2", 2, learns_from_outcome=False) == "lse2/2"
