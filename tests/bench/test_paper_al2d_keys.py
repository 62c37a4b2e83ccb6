"""al2d's job log tells a push job that learns from outcomes from the score-only ones of
earlier runs, so a rerun does not resume the old jobs as if they were the new ones."""

from __future__ import annotations

import pytest

from bench.paper import al2d
from bench.paper.common import JobLog, fit_key
from ltamp_cli.learning.gp import FIT_OBJECTIVE


def test_push_jobs_are_keyed_by_hindsight(monkeypatch: pytest.MonkeyPatch) -> None:
    own = {"budget": 100, "seeds": 5}
    assert al2d._job_key_sizes(own, "pour") == own  # no outcome: logged jobs stay valid
    assert al2d._job_key_sizes(own, "scoop") == own
    assert al2d._job_key_sizes(own, "push") == {**own, "hindsight": True}
    monkeypatch.setattr(al2d, "HINDSIGHT", False)
    assert al2d._job_key_sizes(own, "push") == own


def test_lse_push_jobs_name_their_acquisition() -> None:
    # A job of the earlier default acquisition ("lse/0") must not be resumed as this one.
    fit = f"@{FIT_OBJECTIVE}"
    assert al2d.job_key("lse", 0, learns_from_outcome=True) == "lse+outcome-cover/0" + fit
    assert al2d.job_key("lse", 3, learns_from_outcome=False) == "lse/3" + fit
    assert al2d.job_key("nn-r", 1, learns_from_outcome=True) == "nn-r/1"
    # lse2 chooses by the outcome acquisition too (issue #21, third outcome session)
    assert al2d.job_key("lse2", 2, learns_from_outcome=True) == "lse2+outcome-cover/2" + fit
    assert al2d.job_key("lse2", 2, learns_from_outcome=False) == "lse2/2" + fit


def test_gp_jobs_of_an_earlier_fit_are_rerun(tmp_path) -> None:
    """A GP learner's job logged before the default GP fit changed (key without the fit
    objective) is not read back; a learner without a GP keeps its logged job."""
    from bench.paper.common import Context

    ctx = Context(mode="quick", out=tmp_path, progress=False)
    old = JobLog(ctx, "exp", {"budget": 10})
    old.put("lse/0", [{"success_rate": 0.5}])
    old.put("nn-c/0", [{"success_rate": 0.25}])
    log = JobLog(ctx, "exp", {"budget": 10})
    assert log.get(fit_key("lse/0", "lse")) is None
    assert log.get(fit_key("nn-c/0", "nn-c")) == [{"success_rate": 0.25}]
    assert fit_key("gp/1", "gp") != "gp/1" and fit_key("rf-r/1", "rf-r") == "rf-r/1"
