"""Which physics a trial was simulated with, so that one file never mixes two kinds.

A robot in the loop already changes a record's ``backend`` (``pybullet+panda``). A change to
an engine's settings for one skill (e.g. its PyBullet solver iterations)
keeps the backend's name but changes the labels, so records carry the backend's *physics tag*
(``TrialRecord.physics``, e.g. ``pybullet@v1.1``): the engine's per-skill physics version,
plus a suffix for a what-if setting. :func:`check_physics` is what ``collect`` (resuming a
file) and ``train`` (adding trials to one) use to refuse a file of another physics.

Records written before the field existed have none: they are taken as their engine's base
version (``pybullet@v1``, ``sapien@v3``: the version of every skill's trials before per-skill
revisions), so the 5-iteration scoop trials of an older file are refused by a scoop backend of
``pybullet@v1.1`` while older pour trials (still ``pybullet@v1``) are not.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from ltamp_cli.errors import InputError
from ltamp_cli.trials.record import TrialRecord


def backend_physics(backend: Any, skill: str) -> str | None:
    """The physics tag of ``skill``'s trials on ``backend`` (its ``physics_tag(skill)``), or
    ``None`` for a backend without versioned physics (Box2D, plugins)."""
    tag = getattr(backend, "physics_tag", None)
    return None if tag is None else str(tag(skill))


def legacy_physics(backend: str) -> str | None:
    """The physics of a record of ``backend`` (its ``backend`` field) written without a
    ``physics`` field: its engine's base version, ``None`` for an unversioned backend."""
    engine = backend.split("+", 1)[0]
    if engine == "pybullet":
        from ltamp_cli.backends.pybullet.world import PHYSICS_VERSION as BULLET_VERSION

        return f"pybullet@v{BULLET_VERSION}"
    if engine == "sapien":
        try:
            from ltamp_cli.backends.sapien.world import PHYSICS_VERSION as SAPIEN_VERSION
        except ImportError:  # no SAPIEN here: its records cannot match any backend anyway
            return "sapien@v?"
        return f"sapien@v{SAPIEN_VERSION}"
    return None


def record_physics(record: TrialRecord) -> str | None:
    """The physics ``record`` was simulated with (:func:`legacy_physics` when unrecorded)."""
    return record.physics if record.physics is not None else legacy_physics(record.backend)


def check_physics(records: Iterable[TrialRecord], expected: str | None, where: str,
                  advice: str) -> None:
    """Raise :class:`InputError` (one line: ``where``, both physics tags, ``advice``) when a
    record's physics (:func:`record_physics`) is not ``expected``."""
    for record in records:
        physics = record_physics(record)
        if physics != expected:
            raise InputError(
                f"{where}: holds {record.backend}/{record.skill} trials simulated with physics "
                f"{physics or 'unversioned'}, not {expected or 'unversioned'} as this backend "
                f"runs them; {advice}"
            )
