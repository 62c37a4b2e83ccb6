"""Kitchen3D pictures: replayed states, a camera that follows the arm and what it carries,
a top-view inset into the container being worked on, captions per action."""

from __future__ import annotations

import sys
from contextlib import closing
from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageSequence

from ltamp_cli.backends.frames import GifTiming, caption_height
from ltamp_cli.backends.kitchenware_geometry import VesselDims, vessel_geometry
from ltamp_cli.backends.pybullet.render import Camera
from ltamp_cli.backends.pybullet.replay import BeadGroup, ReplayFrame, ReplayRenderer, ReplayScene
from ltamp_cli.backends.pybullet.robot.arm import PANDA_HOME
from ltamp_cli.backends.pybullet.robot.scene import TableSpec

TABLE_Z = TableSpec().height
#: The executors' camera direction and picture size.
CAMERA = Camera(target=(0.0, 0.0, 0.75), distance=1.3, yaw=50.0, pitch=-30.0)
#: The camera of before (fixed, 320 × 240).
OLD_CAMERA = Camera(target=(0.0, 0.0, 0.75), distance=1.3, yaw=50.0, pitch=-35.0, width=320,
                    height=240)
SCENE = ReplayScene(
    n_arms=1, table=TableSpec(),
    objects={"cup": vessel_geometry(VesselDims(0.06, 0.08, 0.1), kind="cup")},
    beads={"coffee": BeadGroup(count=12, radius=0.006, rgba=(0.35, 0.2, 0.1, 1.0))},
)
CUP_RGB = np.array([0.9, 0.5, 0.2]) * 255
HOME = np.asarray(PANDA_HOME)
REACHING = HOME + np.array([0.6, 0.5, 0.0, 0.8, 0.0, -0.4, 0.0])


def state(q: np.ndarray, cup_xyz: tuple[float, float, float]) -> ReplayFrame:
    """The arm at ``q``; the cup (with its beads inside) at ``cup_xyz`` above the table."""
    cup = np.array([cup_xyz[0], cup_xyz[1], TABLE_Z + cup_xyz[2]])
    beads = cup + np.column_stack([np.linspace(-0.02, 0.02, 12), np.zeros(12),
                                   np.full(12, 0.02)])
    return ReplayFrame(((q, 0.08),), {"cup": (cup, np.array([0.0, 0.0, 0.0, 1.0]))},
                       {"coffee": beads})


def cup_pixels(image: np.ndarray) -> int:
    """Pixels of the cup's colour (lit or shaded: hue kept, brightness varies)."""
    rgb = image.astype(float)
    ratio = rgb / np.maximum(rgb[..., :1], 1.0)
    target = CUP_RGB / CUP_RGB[0]
    return int((np.all(np.abs(ratio - target) < 0.08, axis=-1) & (rgb[..., 0] > 60)).sum())


def test_a_cup_carried_far_up_stays_in_the_following_picture() -> None:
    """Lifted 0.6 m above the table beyond its far corner, the cup leaves the old fixed
    view; the following camera keeps it and the arm in a 640 × 480 picture."""
    far = state(REACHING, (-0.6, 0.6, 0.6))
    with closing(ReplayRenderer(SCENE, OLD_CAMERA)) as fixed:
        assert cup_pixels(fixed.render(far)) == 0
    with closing(ReplayRenderer(SCENE, CAMERA, follow=True)) as renderer:
        near = renderer.render(state(HOME, (0.0, 0.0, 0.0)))
        followed = renderer.render(far)
    assert followed.shape == (480, 640, 3)
    assert cup_pixels(near) > 100 and cup_pixels(followed) > 100


def test_the_inset_looks_into_the_focused_container_only() -> None:
    still = state(REACHING, (0.1, 0.1, 0.0))
    with closing(ReplayRenderer(SCENE, CAMERA, follow=True)) as renderer:
        plain = renderer.render(still).astype(int)
        with_inset = renderer.render(still, "cup").astype(int)
        again = renderer.render(still).astype(int)
    assert np.array_equal(plain, again)  # the arms came back after the inset
    h, w = plain.shape[:2]
    top_right = (slice(0, h // 3), slice(2 * w // 3, w))
    assert np.any(plain[top_right] != with_inset[top_right], axis=-1).mean() > 0.5
    assert np.array_equal(plain[h // 2:, : w // 2], with_inset[h // 2:, : w // 2])
    # Seen from above, the cup fills much of the inset (its rim: the cup's colour).
    assert cup_pixels(with_inset[top_right].astype(np.uint8)) > 0.1 * (h // 3) * (w // 3)


@pytest.mark.slow
def test_a_stir_is_captioned_and_seen_from_above(tmp_path: Path) -> None:
    """A real PyBullet execution (the stir of tests/pybullet): the GIF has a caption per
    action and, while stirring, the top view into the cup."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "pybullet"))
    from test_executor_push_stir import (  # type: ignore[import-not-found]
        CUP_AT,
        STIR_GOOD,
        STIR_WORLD,
        STIRRER_GRASP,
        stir_paths,
    )

    from ltamp_cli.backends.pybullet.executor import ExecutionSettings, Kitchen3DRun
    from ltamp_cli.backends.pybullet.tamp.scene import scene_from_world

    paths = stir_paths(STIR_GOOD)
    run = Kitchen3DRun(scene_from_world(STIR_WORLD), {"cup": CUP_AT, "stirrer": (-0.2, 0.2)},
                       0, ExecutionSettings(), CAMERA)
    try:
        run.held[0] = ("stirrer", STIRRER_GRASP)
        run.pinned.pop("stirrer", None)
        run.film("1/2  move-holding stirrer", None)
        run.run_step("move-holding", [None, None, None, paths[0], None, 0],
                     ["stirrer", "g", "q0", "t0", "q1", "r0"])
        run.film("2/2  stir stirrer cup", "cup")
        run.run_step("stir", ["stirrer", None, "cup", CUP_AT, None, paths[1], 0],
                     ["stirrer", "g", "cup", "pcup", "q1", "t1", "r0"])
        assert run.check("stirred", ("cup",))[0]
        info = run.recorder.save(tmp_path / "stir.gif", GifTiming(fps=4.0, speed=2.0))
    finally:
        run.close()
    with Image.open(tmp_path / "stir.gif") as gif:
        frames = [np.asarray(f.convert("RGB"), dtype=int) for f in ImageSequence.Iterator(gif)]
    assert frames[0].shape == (480, 640, 3) and info["width"] == 640
    band = caption_height(480, 640)
    captions = [(f[-band:].mean(axis=-1) > 128).tobytes() for f in frames]  # the text
    assert len(set(captions)) == 3  # initial state, move-holding, stir
    stirring = [f for f, c in zip(frames, captions, strict=True) if c == captions[-1]]
    others = [f for f, c in zip(frames, captions, strict=True) if c != captions[-1]]
    assert stirring and others
    # Only the stir has the inset; its top view changes as the stirrer turns.
    corner = (slice(8, 140), slice(440, 632))
    assert all(cup_pixels(f[corner].astype(np.uint8)) > 1000 for f in stirring)
    assert all(cup_pixels(f[corner].astype(np.uint8)) < 100 for f in others)
