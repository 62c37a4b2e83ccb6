"""A plugin backend ltamp has never seen, written on the fly for tests.

:func:`install_odd_plugin` writes a package ``ltamp_odd`` and its ``*.dist-info`` (entry
point ``odd`` of group ``ltamp.backends``) into a folder that the ``ltamp`` subprocesses get
on ``PYTHONPATH``: no pip, nothing installed into the venv. Its single skill ``odd`` is
described by a JSON file (``LTAMP_ODD_CONFIG``) that each test writes:

* ``context`` / ``control``: lists of ``[name, low, high]`` (names may repeat or be unicode);
* ``score``: ``ball`` (success within 0.3 of the box's centre, in box-normalised units, on
  the first control), ``fail`` (always -1), ``succeed`` (always +1), ``point`` (success only
  where the first control is exactly the box's centre: a measure-zero set);
* ``score_type``: how the score is returned: ``float``, ``int`` (+1/-1), ``bool``
  (success/failure), ``numpy`` (``np.float32``) or ``0d`` (a 0-d array);
* ``context_draw``: ``uniform`` (default), ``nan``, ``short`` (one value too few) or
  ``outside`` (above the box).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[2]

MODULE = '''
import json
import os
from pathlib import Path

import numpy as np

from ltamp_cli.backends.protocol import ParamSpace, SkillSpec, TrialResult


def _space(rows):
    return ParamSpace(tuple(r[0] for r in rows), tuple(float(r[1]) for r in rows),
                      tuple(float(r[2]) for r in rows))


class OddBackend:
    name = "odd"

    def __init__(self, **options):
        self.config = json.loads(Path(os.environ["LTAMP_ODD_CONFIG"]).read_text())
        self.spec = SkillSpec("odd", _space(self.config["context"]),
                              _space(self.config["control"]), deterministic=True)

    def skills(self):
        return {"odd": self.spec}

    def sample_context(self, skill, rng):
        space = self.spec.context
        draw = self.config.get("context_draw", "uniform")
        if draw == "nan":
            return np.full(space.dim, np.nan)
        if draw == "short":
            return np.zeros(max(space.dim - 1, 0))
        if draw == "outside":
            return space.high_array() + 1.0
        return space.sample_uniform(rng, 1)[0]

    def is_valid(self, skill, context, controls):
        return np.ones(len(np.atleast_2d(controls)), dtype=bool)

    def success(self, control):
        space = self.spec.control
        lows, highs = space.low_array(), space.high_array()
        width = np.where(highs > lows, highs - lows, 1.0)
        u = (np.asarray(control, dtype=float)[0] - lows[0]) / width[0] - 0.5
        kind = self.config["score"]
        if kind == "ball":
            return 0.3 - abs(u)
        if kind == "fail":
            return -1.0
        if kind == "succeed":
            return 1.0
        if kind == "point":
            return 1.0 if u == 0.0 else -abs(u)
        raise ValueError(kind)

    def run_trial(self, skill, context, control, seed):
        score = float(self.success(control))
        kind = self.config.get("score_type", "float")
        if kind == "int":
            value = 1 if score > 0 else -1
        elif kind == "bool":
            value = bool(score > 0)
        elif kind == "numpy":
            value = np.float32(score)
        elif kind == "0d":
            value = np.array(score)
        else:
            value = score
        return TrialResult(value, True, {})

    def close(self):
        pass


def make_backend(**options):
    return OddBackend(**options)
'''


def install_odd_plugin(site: Path) -> Path:
    """Write the plugin into ``site`` (created); returns ``site``."""
    package = site / "ltamp_odd"
    package.mkdir(parents=True, exist_ok=True)
    (package / "__init__.py").write_text(MODULE)
    info = site / "ltamp_odd-0.1.dist-info"
    info.mkdir(exist_ok=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: ltamp-odd\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[ltamp.backends]\nodd = ltamp_odd:make_backend\n")
    return site


def odd_env(site: Path, config: dict[str, Any], where: Path) -> dict[str, str]:
    """The environment of an ``ltamp`` subprocess that sees the plugin configured by
    ``config`` (written to ``where/odd.json``)."""
    path = where / "odd.json"
    path.write_text(json.dumps(config, ensure_ascii=False))
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(site), str(REPO)]),
            "LTAMP_ODD_CONFIG": str(path), "OMP_NUM_THREADS": "1",
            "XDG_CACHE_HOME": str(where / "cache")}
