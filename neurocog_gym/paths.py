"""The one place that knows where the shipped assets live.

The top-level ``assets/`` folder of the source tree is the design card's choice; the wheel carries
a copy under ``neurocog_gym/assets`` (see ``setup.py``/``pyproject.toml``). Both an editable install
and a plain ``pip install .`` therefore resolve to a real folder.
"""

from __future__ import annotations

import os
from pathlib import Path

_PKG_DIR = Path(__file__).resolve().parent


def assets_dir() -> Path:
    """Return the folder that holds the MJCF files, the default gait and the AEF weights.

    Order: ``$NEUROCOG_ASSETS`` if set, the copy inside the installed package, then the
    source tree's top-level ``assets/``.
    """
    env = os.environ.get("NEUROCOG_ASSETS")
    if env:
        return Path(env)
    for candidate in (_PKG_DIR / "assets", _PKG_DIR.parent / "assets"):
        if (candidate / "scene.xml").is_file():
            return candidate
    raise FileNotFoundError(
        "neurocog_gym assets not found: expected scene.xml in "
        f"{_PKG_DIR / 'assets'} or {_PKG_DIR.parent / 'assets'}; reinstall the package "
        "or set NEUROCOG_ASSETS"
    )


def asset(name: str) -> Path:
    """Return the path of one shipped asset file, with a clear error if it is missing."""
    path = assets_dir() / name
    if not path.exists():
        raise FileNotFoundError(f"asset {name!r} is missing from {assets_dir()}")
    return path


ROBOT_XML = "quadruped.xml"
SCENE_XML = "scene.xml"
DEFAULT_GAIT = "default_gait.json"
AEF_WEIGHTS = "aef_weights.npz"
PPO_MODEL = "ppo_sudden/model.zip"
"""The shipped PPO policy (``make_policy("ppo")``), with ``vecnormalize.pkl`` beside it."""
