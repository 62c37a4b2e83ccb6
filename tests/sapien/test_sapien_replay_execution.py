"""`--render` on SAPIEN without a render device: the execution is replayed on the CPU."""

from __future__ import annotations

import math
import types
from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageSequence

pytest.importorskip("sapien")

from ltamp_cli.backends.frames import GifTiming
from ltamp_cli.backends.pybullet.executor import ExecutionSettings
from ltamp_cli.backends.pybullet.robot.arm import PANDA_HOME
from ltamp_cli.backends.pybullet.tamp.values import ArmPath
from ltamp_cli.backends.sapien.executor import SapienKitchen3DExecutor
from ltamp_cli.backends.sapien.render import probe_render_device
from ltamp_cli.planner.problem import load_problem

ROOT = Path(__file__).resolve().parents[2]
POUR_BLOCKED = ROOT / "problems" / "kitchen3d" / "pour_blocked.yaml"


@pytest.fixture(scope="module")
def no_device() -> None:
    probe = probe_render_device()
    if probe.available:
        pytest.skip("this machine has a rendering device: SAPIEN renders itself")


def _gif_frames(path: Path) -> tuple[list[np.ndarray], int]:
    """The GIF's distinct frames ``(h, w, 3)`` and how many frames were saved: PIL merges
    identical consecutive frames into one that lasts as long as all of them, so that is
    the total duration over one frame's duration."""
    with Image.open(path) as gif:
        frames = [
            (np.asarray(frame.convert("RGB")), int(frame.info["duration"]))
            for frame in ImageSequence.Iterator(gif)
        ]
    durations = [duration for _, duration in frames]
    assert all(duration % min(durations) == 0 for duration in durations)
    return [image for image, _ in frames], sum(durations) // min(durations)


@pytest.mark.slow
def test_a_moving_arm_is_replayed_into_a_gif(
    no_device: None, tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    """A one-step plan (a free motion of the arm away from home) executed in SAPIEN."""
    home = np.asarray(PANDA_HOME)
    away = home + np.array([0.9, 0.4, 0.0, 0.9, 0.0, -0.5, 0.0])
    path = ArmPath(0, np.linspace(home, away, 30), "free")
    plan = types.SimpleNamespace(
        plan=[types.SimpleNamespace(name="move-free", values=[None, path, None, None],
                                    args=None)]
    )
    every = 24
    # Real time at one GIF frame per recorded state (240 Hz / 24 = 10 fps): nothing skipped.
    executor = SapienKitchen3DExecutor(ExecutionSettings(render_every=every),
                                       timing=GifTiming(fps=10.0, speed=1.0))
    report = executor.execute(
        load_problem(POUR_BLOCKED), plan, seed=0, render_path=tmp_path / "out.gif"
    )
    assert report.success, report.details["steps"]
    assert "TinyRenderer" in capfd.readouterr().err
    gif = Path(report.details["render"])
    assert gif == tmp_path / "out.gif" and gif.is_file()
    frames, saved = _gif_frames(gif)
    # The execution's states, then one more second captioned with the goal's outcome.
    recorded = math.ceil(report.details["sim_steps"] / every) + 240 // every
    assert saved == recorded and 3 <= len(frames) <= recorded
    assert frames[0].shape == (480, 640, 3)
    assert all(frame.std() > 10 for frame in frames)  # not blank
    # The arm moved: the last frame differs from the first in a sizeable area, while the
    # settling frames at the start (nothing but beads moving) differ far less.
    changed = float(np.any(frames[0] != frames[-1], axis=-1).mean())
    settling = float(np.any(frames[0] != frames[1], axis=-1).mean())
    assert changed > 0.01 and changed > 3 * settling
