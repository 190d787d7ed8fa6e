"""scripts/bench_env.py end to end on a tiny budget (its numbers are not checked: speed is
measured by the script, never asserted in a test)."""

import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "bench_env.py"


@pytest.mark.slow
def test_env_part_writes_every_row(tmp_path):
    out = tmp_path / "env.md"
    r = subprocess.run([sys.executable, str(SCRIPT), "--part", "env", "--rounds", "1",
                        "--steps", "5", "--full-steps", "2", "--vec-steps", "2",
                        "--profile-steps", "5", "--out", str(out)],
                       capture_output=True, text=True, timeout=600)  # fmt: skip
    assert r.returncode == 0, r.stderr
    text = out.read_text()
    for row in ("full perception, default settings", "`Ant-v5`, random actions",
                "154,112 rays a frame", "'async')", "'sync')", "load average",
                "ToF sensing", "**whole step**", "| pinned + FlattenObservation |",
                "two independent processes", "inside `env.step`"):  # fmt: skip
        assert row in text


def test_bad_arguments_exit_2():
    r = subprocess.run([sys.executable, str(SCRIPT), "--part", "nope"], capture_output=True,
                       text=True, timeout=120)  # fmt: skip
    assert r.returncode == 2 and "--part" in r.stderr
    r = subprocess.run([sys.executable, str(SCRIPT), "--rounds", "0"], capture_output=True,
                       text=True, timeout=120)  # fmt: skip
    assert r.returncode == 2 and "counts" in r.stderr
