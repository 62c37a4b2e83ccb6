"""The physics a Kitchen3D skill trial needs: the one interface every 3D engine implements.

A skill (:mod:`.pour`, :mod:`.scoop`, :mod:`.push`, :mod:`.stir`) is written once against
:class:`TrialPhysics`; an engine (PyBullet: :mod:`ltamp_cli.backends.pybullet.skills.physics`,
SAPIEN: :mod:`ltamp_cli.backends.sapien.skills`) supplies these few operations and nothing
about the skill. A fix to a skill or a new engine therefore touches one place.

The interface
-------------
* :meth:`TrialPhysics.reset` starts an empty scene: the table (a plane at ``z = 0``) only.
* :meth:`TrialPhysics.add_body` adds a kitchenware body (its convex pieces, one rigid body)
  with a :class:`~ltamp_cli.backends.pybullet.kitchenware.BodyMaterial`, in one of three
  roles (:data:`BodyRole`):

  - ``"fixed"``: never moves (a bowl on the table); the material's mass is ignored;
  - ``"free"``: dynamic, weighs ``material.mass`` kg (a pushed block, a stirred cup);
  - ``"tool"``: moved along a path by :meth:`TrialPhysics.follow` and kept still by
    :meth:`TrialPhysics.hold` (a free-floating cup, spoon, fingertip pad or stirrer). It
    pushes what it touches and nothing pushes it back.

* :meth:`TrialPhysics.spawn_beads_in` fills a vessel body with
  :class:`~ltamp_cli.backends.pybullet.particles.BeadSpec` spheres on the shared jittered
  grid (same draws from ``rng`` on every engine); :meth:`BeadSet.positions` reads them.
* :meth:`TrialPhysics.follow` moves a tool through a timed :class:`PosePath`, one pose per
  simulation step: step ``i`` carries the tool from pose ``i`` to pose ``i + 1`` with the
  velocity that implies (so contacts push beads), and the tool ends at the last pose.
* :meth:`TrialPhysics.hold` steps the simulation with a tool kept still at a pose.
* :meth:`TrialPhysics.steps_for` and :attr:`TrialPhysics.time_step` convert simulated time.

Both ``follow`` and ``hold`` call ``on_step(step_offset + i)`` after each step ``i`` (for
recording frames or tracking a tip) and return the number of steps taken. Poses everywhere
are a position ``(3,)`` in metres and a quaternion ``(4,)`` in ``(x, y, z, w)`` order.

What is measured from a scene (:func:`contained_mask`, :func:`count_lost`, body poses) is
engine-independent and lives here too.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal, Protocol

import numpy as np
from scipy.spatial.transform import Rotation

from ltamp_cli.backends.kitchenware_geometry import KitchenwareGeometry
from ltamp_cli.backends.pybullet.kitchenware import BodyMaterial
from ltamp_cli.backends.pybullet.particles import BeadSpec, count_lost
from ltamp_cli.backends.pybullet.paths import PosePath

StepCallback = Callable[[int], None]
BodyRole = Literal["fixed", "free", "tool"]
IDENTITY_QUAT = np.array([0.0, 0.0, 0.0, 1.0])


class SimBody(Protocol):
    """A body in an engine's scene: the geometry it was built from and its current pose."""

    @property
    def geometry(self) -> KitchenwareGeometry: ...

    def pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Position ``(3,)`` m and quaternion ``(4,)`` xyzw of the object frame."""
        ...


class BeadSet(Protocol):
    """The beads of one trial."""

    def __len__(self) -> int: ...

    def positions(self) -> np.ndarray:
        """World positions ``(n, 3)`` of the bead centres, metres."""
        ...


class TrialPhysics(Protocol):
    """What a Kitchen3D skill trial asks of a physics engine (see the module docstring)."""

    @property
    def time_step(self) -> float:
        """Seconds of simulated time per step."""
        ...

    def reset(self) -> None: ...

    def steps_for(self, seconds: float) -> int: ...

    def add_body(
        self,
        geometry: KitchenwareGeometry,
        material: BodyMaterial,
        role: BodyRole,
        position: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
        quaternion: Sequence[float] | np.ndarray = IDENTITY_QUAT,
    ) -> SimBody: ...

    def spawn_beads_in(
        self, container: SimBody, spec: BeadSpec, rng: np.random.Generator
    ) -> BeadSet: ...

    def follow(
        self, tool: SimBody, path: PosePath, on_step: StepCallback | None = None,
        step_offset: int = 0,
    ) -> int: ...

    def hold(
        self, tool: SimBody, position: np.ndarray, quaternion: np.ndarray, steps: int,
        on_step: StepCallback | None = None, step_offset: int = 0,
    ) -> int: ...


class _TimeStepped(Protocol):
    @property
    def time_step(self) -> float: ...


class SteppedWorld(Protocol):
    """An engine's world: reset to the table only, stepped, ``config.time_step`` seconds a step."""

    @property
    def config(self) -> _TimeStepped: ...

    def reset(self) -> None: ...

    def step(self, n: int = 1) -> None: ...

    def steps_for(self, seconds: float) -> int: ...


@dataclass(frozen=True, eq=False)
class WorldPhysics:
    """What every engine's :class:`TrialPhysics` shares: the world's clock and the stepping
    loop. An engine adds ``add_body``, ``spawn_beads_in``, ``follow`` and ``hold``."""

    world: SteppedWorld

    @property
    def time_step(self) -> float:
        return self.world.config.time_step

    def reset(self) -> None:
        self.world.reset()

    def steps_for(self, seconds: float) -> int:
        return self.world.steps_for(seconds)

    def run_steps(self, count: int, before_step: Callable[[int], None] | None,
                  on_step: StepCallback | None, step_offset: int) -> int:
        """Step ``count`` times, calling ``before_step(i)`` before and
        ``on_step(step_offset + i)`` after step ``i``; returns ``count``."""
        for i in range(count):
            if before_step is not None:
                before_step(i)
            self.world.step()
            if on_step is not None:
                on_step(step_offset + i)
        return count


def world_to_object(
    points: np.ndarray, position: np.ndarray, quaternion: np.ndarray
) -> np.ndarray:
    """World points ``(n, 3)`` in the frame at ``position`` ``(3,)`` with ``quaternion``
    ``(4,)`` xyzw: ``(n, 3)``."""
    rotation = Rotation.from_quat(np.asarray(quaternion, dtype=float)).as_matrix()
    return (np.asarray(points, dtype=float).reshape(-1, 3) - np.asarray(position)) @ rotation


def contained_mask(container: SimBody, positions_world: np.ndarray) -> np.ndarray:
    """Bool mask ``(n,)``: which bead centres ``(n, 3)`` lie in ``container``'s
    containment prism at its current pose."""
    prism = container.geometry.cavity
    if prism is None:
        raise ValueError(f"a {container.geometry.kind} has no cavity to contain beads")
    return prism.contains(world_to_object(positions_world, *container.pose()))


__all__ = [
    "IDENTITY_QUAT",
    "BeadSet",
    "BodyRole",
    "SimBody",
    "StepCallback",
    "SteppedWorld",
    "TrialPhysics",
    "WorldPhysics",
    "contained_mask",
    "count_lost",
    "world_to_object",
]
