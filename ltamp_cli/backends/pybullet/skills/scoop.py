"""Former import path of :mod:`ltamp_cli.backends.skills3d.scoop`, where the Kitchen3D skills
are defined once for every engine; kept so that existing imports keep working."""

from ltamp_cli.backends.skills3d.scoop import *  # noqa: F403
