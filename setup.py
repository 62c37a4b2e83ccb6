"""Build step of the wheel: the repository's shipped folders become package data.

``domains/``, ``problems/`` and ``models/`` stay at the top of the repository; a (non-editable)
build copies them to ``ltamp_cli/_shipped/`` so that an installed ltamp finds them through
``importlib.resources`` (see ``ltamp_cli/shipped.py``). Editable installs read the checkout.
All other metadata is in ``pyproject.toml``.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

SHIPPED_FOLDERS = ("domains", "problems", "models")
IGNORED = shutil.ignore_patterns("__pycache__", "*.pyc", "*.pyo")


class BuildPyWithShippedData(build_py):
    """``build_py`` plus a copy of the shipped folders into the built package."""

    def run(self) -> None:
        super().run()
        if getattr(self, "editable_mode", False):
            return
        source = Path(__file__).resolve().parent
        target = Path(self.build_lib) / "ltamp_cli" / "_shipped"
        for name in SHIPPED_FOLDERS:
            shutil.copytree(source / name, target / name, ignore=IGNORED, dirs_exist_ok=True)


setup(cmdclass={"build_py": BuildPyWithShippedData})
