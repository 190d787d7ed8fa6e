"""Build hook: copy the top-level ``assets/`` folder into the wheel as ``neurocog_gym/assets``.

All metadata lives in ``pyproject.toml``; this file only makes a non-editable ``pip install .``
carry the MJCF files, the default gait and the AEF weights (resolved by ``neurocog_gym.paths``).
"""

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py


class BuildPyWithAssets(build_py):
    """``build_py`` that also copies ``assets/`` into the built package."""

    def run(self):
        """Build as usual, then copy the assets."""
        super().run()
        src = Path(__file__).resolve().parent / "assets"
        if src.is_dir():
            dst = Path(self.build_lib) / "neurocog_gym" / "assets"
            shutil.copytree(src, dst, dirs_exist_ok=True)


setup(cmdclass={"build_py": BuildPyWithAssets})
