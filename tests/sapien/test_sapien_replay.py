"""The CPU replay renderer: recorded actor states drawn with PyBullet's TinyRenderer."""

from __future__ import annotations

import math
from contextlib import closing

import numpy as np
import pytest

from ltamp_cli.backends.kitchenware_geometry import VesselDims, vessel_geometry
from ltamp_cli.backends.pybullet.render import Camera
from ltamp_cli.backends.pybullet.robot.arm import PANDA_HOME
from ltamp_cli.backends.pybullet.robot.scene import TableSpec
from ltamp_cli.backends.sapien.replay import (
    BeadGroup,
    ReplayFrame,
    ReplayRecorder,
    ReplayRenderer,
    ReplayScene,
    render_replay,
)

TABLE_Z = TableSpec().height
CAMERA = Camera(target=(0.0, 0.0, 0.75), distance=1.3, yaw=50.0, pitch=-35.0, width=160,
                height=120)
SCENE = ReplayScene(
    n_arms=1,
    table=TableSpec(),
    objects={"cup": vessel_geometry(VesselDims(0.06, 0.08, 0.1), kind="cup")},
    beads={"water": BeadGroup(count=12, radius=0.006)},
)
BEADS = np.column_stack([np.linspace(-0.02, 0.02, 12), np.zeros(12), np.full(12, TABLE_Z + 0.17)])
IDENTITY = np.array([0.0, 0.0, 0.0, 1.0])


def frame(q: np.ndarray, cup_xy: tuple[float, float], beads: np.ndarray) -> ReplayFrame:
    return ReplayFrame(
        arms=((q, 0.08),),
        objects={"cup": (np.array([*cup_xy, TABLE_Z]), IDENTITY)},
        beads={"water": beads},
    )


HOME = np.asarray(PANDA_HOME)
REACHING = HOME + np.array([0.6, 0.5, 0.0, 0.8, 0.0, -0.4, 0.0])
START = frame(HOME, (0.0, 0.0), BEADS)
END = frame(REACHING, (0.15, 0.1), BEADS + np.array([0.15, 0.1, 0.0]))


def _changed(a: np.ndarray, b: np.ndarray) -> float:
    """Fraction of pixels whose colour differs."""
    return float(np.any(a != b, axis=-1).mean())


def test_a_two_frame_trajectory_renders_the_recorded_states() -> None:
    images = render_replay(SCENE, [START, END], CAMERA)
    assert len(images) == 2
    for image in images:
        assert image.shape == (120, 160, 3) and image.dtype == np.uint8
        # Not blank: the table, arm and cup give many distinct colours.
        assert image.std() > 10 and len(np.unique(image.reshape(-1, 3), axis=0)) > 50
    # The arm and the cup moved between the frames: a sizeable part of the image changes.
    assert _changed(images[0], images[1]) > 0.02


def test_each_actor_is_drawn_where_the_frame_puts_it() -> None:
    with closing(ReplayRenderer(SCENE, CAMERA)) as renderer:
        start = renderer.render(START)
        # Rendering is a pure function of the recorded state.
        assert np.array_equal(renderer.render(END), renderer.render(END))
        assert np.array_equal(renderer.render(START), start)
        arm_only = renderer.render(frame(REACHING, (0.0, 0.0), BEADS))
        cup_only = renderer.render(frame(HOME, (0.15, 0.1), BEADS))
        hidden = BEADS.copy()
        hidden[:, 2] = math.nan  # non-finite beads are hidden, not a crash
        no_beads = renderer.render(frame(HOME, (0.0, 0.0), hidden))
    assert _changed(start, arm_only) > 0.01
    assert _changed(start, cup_only) > 0.002
    assert 0.0 < _changed(start, no_beads) < _changed(start, arm_only)


def test_a_frame_that_does_not_match_the_scene_is_refused() -> None:
    with closing(ReplayRenderer(SCENE, CAMERA)) as renderer:
        with pytest.raises(ValueError, match="beads"):
            renderer.render(frame(HOME, (0.0, 0.0), BEADS[:5]))
        with pytest.raises(ValueError, match="arms"):
            renderer.render(ReplayFrame((), START.objects, START.beads))


def test_the_recorder_keeps_every_nth_state_and_renders_once() -> None:
    states = iter([START, END] * 10)
    recorder = ReplayRecorder(SCENE, lambda: next(states), every=4, camera=CAMERA)
    for step in range(7):
        recorder(step)
    assert len(recorder.recorded) == math.ceil(7 / 4)
    frames = recorder.frames
    assert len(frames) == 2 and recorder.frames is frames
    assert _changed(frames[0], frames[1]) > 0.02
