"""SAPIEN rendering is optional: a missing device is a clear message, never a crash."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("sapien")

from ltamp_cli.backends import load_backend
from ltamp_cli.backends.pybullet.skills.pour import NOMINAL_BOWL, NOMINAL_CUP, PourContext
from ltamp_cli.backends.sapien import render
from ltamp_cli.backends.sapien.render import (
    RendererUnavailable,
    probe_render_device,
    require_renderer,
)

CONTEXT = PourContext(NOMINAL_BOWL, NOMINAL_CUP).to_array()
GOOD = np.array([-3 * math.pi / 4, -0.5, 0.5, 0.15, 0.12])


@pytest.fixture(scope="module")
def probe() -> render.RenderProbe:
    return probe_render_device()


def test_a_crashing_or_raising_probe_is_reported_not_fatal(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(render, "_PROBE", "import os\nos.abort()\n")
    crashed = probe_render_device()
    assert not crashed.available and "crashed" in crashed.reason
    monkeypatch.setattr(render, "_PROBE", "raise RuntimeError('no vulkan here')\n")
    raised = probe_render_device()
    assert not raised.available and raised.reason.endswith("no vulkan here")
    with pytest.raises(RendererUnavailable, match=r"cannot render .*no vulkan here"):
        require_renderer(raised)


def test_record_trial_without_a_device_raises_one_clear_message(
    probe: render.RenderProbe,
) -> None:
    if probe.available:
        pytest.skip("this machine has a rendering device")
    assert probe.reason  # e.g. "RuntimeError: failed to find a rendering device"
    backend = load_backend("sapien")
    with pytest.raises(RendererUnavailable) as error:
        backend.record_trial("pour", CONTEXT, GOOD, seed=0)
    message = str(error.value)
    assert "\n" not in message and probe.reason in message
    # Physics still works after the refusal.
    assert backend.run_trial("pour", CONTEXT, GOOD, seed=0).score > 0
    backend.close()


@pytest.mark.slow
def test_record_trial_renders_frames_when_a_device_exists(probe: render.RenderProbe) -> None:
    if not probe.available:
        pytest.skip(f"no rendering device: {probe.reason}")
    backend = load_backend("sapien")
    result, frames = backend.record_trial("pour", CONTEXT, GOOD, seed=0, every=40)
    plain = backend.run_trial("pour", CONTEXT, GOOD, seed=0)
    backend.close()
    assert result.score == pytest.approx(plain.score)
    assert len(frames) == math.ceil(result.info["sim_steps"] / 40)
    assert frames[0].shape == (240, 320, 3) and frames[0].dtype == np.uint8
    # The cup moves: the first and the middle frame differ.
    assert np.abs(frames[0].astype(int) - frames[len(frames) // 2].astype(int)).mean() > 0.5
