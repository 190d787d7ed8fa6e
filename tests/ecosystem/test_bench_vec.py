"""scripts/bench_vec.py end to end on a tiny budget (its numbers are not checked: speed is
measured by the script, never asserted in a test)."""

import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "bench_vec.py"


def test_writes_every_row_with_machine_command_and_load(tmp_path):
    out = tmp_path / "vec.md"
    r = subprocess.run([sys.executable, str(SCRIPT), "--ids", "NeuroCog/Walk-v3", "--ns", "2",
                        "--rounds", "1", "--steps", "3", "--out", str(out)],
                       capture_output=True, text=True, timeout=600)  # fmt: skip
    assert r.returncode == 0, r.stderr
    text = out.read_text()
    for row in ("Machine:", "Command: `python scripts/bench_vec.py --ids", "`uptime` before",
                "| one env (`gymnasium.make`), its own episode | 1 |", "one env at a time",
                "`SyncVectorEnv`", "`SpinVectorEnv`",
                "`BatchVectorEnv` (`vector_backend='threads'`) | 2 |", ">= 1.85"):  # fmt: skip
        assert row in text


def test_bad_arguments_are_clear_errors():
    r = subprocess.run([sys.executable, str(SCRIPT), "--ids", "NeuroCog/Nope-v9", "--out", ""],
                       capture_output=True, text=True, timeout=120)  # fmt: skip
    assert r.returncode == 2 and "unknown env ids" in r.stderr
