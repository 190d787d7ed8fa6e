"""scripts/bench_env_compare.py end to end against this checkout's own HEAD (its speed numbers
are not checked: speed is measured by the script, never asserted in a test)."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "scripts" / "bench_env_compare.py"


@pytest.mark.slow
def test_compare_against_head_reports_the_same_episodes(tmp_path):
    if not (ROOT / ".git").exists():
        pytest.skip("needs a git checkout (the baseline is a worktree of a commit)")
    out = tmp_path / "compare.md"
    r = subprocess.run([sys.executable, str(SCRIPT), "--baseline", "HEAD", "--rounds", "1",
                        "--seconds", "0.3", "--out", str(out)],
                       capture_output=True, text=True, timeout=900)  # fmt: skip
    assert r.returncode == 0, r.stderr
    text = out.read_text()
    assert "**identical**" in text  # HEAD against the working tree: nothing altered
    assert "Paired within each round" in text and "`Ant-v5`, random actions" in text


def test_bad_arguments_exit_2():
    r = subprocess.run([sys.executable, str(SCRIPT), "--rounds", "0"], capture_output=True,
                       text=True, timeout=120)  # fmt: skip
    assert r.returncode == 2 and "--rounds" in r.stderr
