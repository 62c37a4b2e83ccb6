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
from dataclasses import dataclass
from typing import Any

from ltamp_cli.errors import InputError
from ltamp_cli.trials.record import TrialRecord, setup_words

#: The ``backend`` field of records imported from outside any simulator (``ltamp import``:
#: ``import:<file name>``), e.g. real-robot trials: they have no physics or setup of ours to
#: compare, so :func:`check_trial_kind` lets them into any pool (as pools always have).
IMPORTED_PREFIX = "import:"


def backend_physics(backend: Any, skill: str) -> str | None:
    """The physics tag of ``skill``'s trials on ``backend`` (its ``physics_tag(skill)``), or
    ``None`` for a backend without versioned physics (Box2D, plugins).

    A plugin's ``physics_tag`` may answer ``None`` (unversioned, as if it had no such method:
    its older records without the field still match) or a non-empty string; anything else,
    or an exception other than ``KeyError`` (an unknown skill), is one
    :class:`InputError` line naming the backend — a ``str()`` of it would be written into
    every record (``"None"``, ``"5"``) and refuse the plugin's own older files.
    """
    from ltamp_cli.backends.protocol import optional_version

    return optional_version(backend, "physics_tag", skill)


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


@dataclass(frozen=True)
class TrialKind:
    """What two trials must share for their labels to be learned together: the records'
    ``backend`` tag (``pybullet``, ``pybullet+panda``), the robot ``setup`` and the
    ``physics`` (:func:`record_physics`; ``None`` for an unversioned engine)."""

    backend: str
    setup: str | None
    physics: str | None

    @classmethod
    def of_record(cls, record: TrialRecord) -> TrialKind:
        return cls(record.backend, record.setup, record_physics(record))

    @classmethod
    def of_backend(cls, backend: Any, skill: str) -> TrialKind:
        """The kind of ``skill``'s trials run on ``backend`` now (its name, ``trial_setup``
        and ``physics_tag``)."""
        from ltamp_cli.backends.protocol import trial_setup

        return cls(str(backend.name), trial_setup(backend, skill), backend_physics(backend, skill))

    def differences(self, expected: TrialKind) -> list[str]:
        """``"<field> <mine>, not <expected's>"`` for each field that differs."""
        words = []
        if self.backend != expected.backend:
            words.append(f"backend {self.backend}, not {expected.backend}")
        if self.setup != expected.setup:
            words.append(f"{setup_words(self.setup)}, not {setup_words(expected.setup)}")
        if self.physics != expected.physics:
            words.append(f"physics {self.physics or 'unversioned'}, not "
                         f"{expected.physics or 'unversioned'}")
        return words


def check_trial_kind(records: Iterable[tuple[str, TrialRecord]],
                     expected: TrialKind | None, against: str, advice: str) -> TrialKind | None:
    """Raise :class:`InputError` at the first record whose :class:`TrialKind` is not
    ``expected``, in one line: the record's location (``where``, e.g. ``file:line``), each
    differing field with both values, ``against`` (what the expected kind is) and
    ``advice``. ``expected=None``: the first record's kind, so the records must at least be
    of one kind. Records imported from outside any simulator (:data:`IMPORTED_PREFIX`) are
    not checked. Returns the kind checked against (``None`` if there was none)."""
    for where, record in records:
        if record.backend.startswith(IMPORTED_PREFIX):
            continue
        kind = TrialKind.of_record(record)
        if expected is None:
            expected, against = kind, f"as in {where}"
            continue
        differences = kind.differences(expected)
        if differences:
            raise InputError(
                f"{where}: a {record.backend}/{record.skill} trial of "
                f"{'; '.join(differences)} ({against}); labels of two kinds of trial differ: "
                f"{advice}")
    return expected
