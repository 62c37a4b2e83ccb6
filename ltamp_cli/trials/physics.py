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
    ``None`` for a backend without versioned physics (Box2D, plugins).

    A plugin's ``physics_tag`` may answer ``None`` (unversioned, as if it had no such method:
    its older records without the field still match) or a non-empty string; anything else,
    or an exception other than ``KeyError`` (an unknown skill), is one
    :class:`InputError` line naming the backend — a ``str()`` of it would be written into
    every record (``"None"``, ``"5"``) and refuse the plugin's own older files.
    """
    method = getattr(backend, "physics_tag", None)
    if method is None:
        return None
    where = f"backend {getattr(backend, 'name', '?')!r} ({type(backend).__module__})"
    try:
        tag = method(skill)
    except KeyError:
        raise  # an unknown skill, as skill_spec reports it
    except Exception as error:  # a plugin's bug: one line naming it, not a traceback
        raise InputError(f"{where}: physics_tag({skill!r}) raised "
                         f"{type(error).__name__}: {error}") from None
    if tag is None or (isinstance(tag, str) and tag.strip()):
        return tag
    raise InputError(f"{where}: physics_tag({skill!r}) returned {tag!r:.40}: expected None "
                     "or a non-empty string")


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
