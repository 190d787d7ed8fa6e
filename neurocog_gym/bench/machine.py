"""The machine line every benchmark report starts with (used by ``scripts/bench_*.py``).

A figure without the machine it was measured on cannot be compared with anything; each script
writes :func:`machine` (CPU model, logical CPUs, OS, Python and the versions of the packages
whose speed it measures) next to its table.
"""

from __future__ import annotations

import importlib
import os
import platform
import re
from pathlib import Path

_DISPLAY = {
    "mujoco": "MuJoCo",
    "numpy": "NumPy",
    "numba": "Numba",
    "gymnasium": "Gymnasium",
    "stable_baselines3": "stable-baselines3",
    "torch": "torch",
}


def cpu_model() -> str:
    """The CPU's model name from /proc/cpuinfo (Linux), else what ``platform`` knows."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def machine(*packages: str, pinned: bool = False) -> str:
    """One line: CPU, logical CPUs, OS, Python and the versions of ``packages`` (module names).

    Args:
        packages: importable module names, e.g. ``"mujoco", "numpy"``.
        pinned: the script pins itself to one CPU (said in the line).
    """
    cpus = f"{os.cpu_count()} logical CPUs" + (" (pinned to one)" if pinned else "")
    parts = [f"Python {platform.python_version()}"]
    for name in packages:
        parts.append(f"{_DISPLAY.get(name, name)} {importlib.import_module(name).__version__}")
    return f"{cpu_model()}, {cpus}, {platform.system()} {platform.release()}; " + ", ".join(parts)


def field_doc(source: str | os.PathLike, name: str) -> str:
    """The docstring under the dataclass field ``name`` in the file ``source`` (for --help)."""
    src = Path(source).read_text()
    m = re.search(rf"^    {name}: [^\n]*\n    \"\"\"(.*?)\"\"\"", src, flags=re.M | re.S)
    return " ".join(m.group(1).split()).replace("%", "%%") if m else ""
