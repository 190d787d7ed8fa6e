"""scripts/env_speed_history.py: the rows it reads from a committed bench_env report."""

import importlib.util
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "env_speed_history.py"
_spec = importlib.util.spec_from_file_location("env_speed_history", SCRIPT)
history = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(history)

REPORT = """## Env throughput (`scripts/bench_env.py`)

Machine: AMD EPYC, 2 logical CPUs, Linux 6.18; Python 3.11.7.

| row | env steps/s | simulated s per wall s | ratio | target | met |
|---|---:|---:|---:|---:|:-:|
| `NeuroCog/SuddenObstacle-v0`, full perception, default settings (ToF 4 x 56 x 43), zero actions | 1,577 | 15.8 | 0.54x Ant-v5 | >= 0.5x | yes |
| `Ant-v5`, random actions | 2,943 | 147.1 | 1 | | |
| `gymnasium.make_vec('NeuroCog/SuddenObstacle-v0', 2)`: the registered vector entry point, `SpinVectorEnv` | 2,042 | 20.4 | 1.29x 1 env (1.28x paired, rounds 1.19-1.54) | >= 1.6x | no |
| `gymnasium.make_vec('NeuroCog/SuddenObstacle-v0', 2, 'async')`: Gymnasium's `AsyncVectorEnv` | 1,055 | 10.6 | 0.67x 1 env (0.68x paired) | >= 1.6x | no |
"""  # noqa: E501


def test_parse_reads_the_machine_and_the_four_rows():
    row = history.parse(REPORT)
    assert row == {
        "cpu": "AMD EPYC",
        "env": "1,577",
        "ant": "2,943",
        "ratio": "0.54 ×",
        "spin": "1.29 × (1.28 × paired, rounds 1.19-1.54)",
        "async": "0.67 × (0.68 × paired)",
    }


def test_parse_skips_a_report_without_the_env_rows():
    assert history.parse("## Env throughput\n\nMachine: X, 2 logical CPUs\n") is None
    # Older reports without the vector rows still give the env and Ant-v5 figures.
    older = "\n".join(line for line in REPORT.splitlines() if "make_vec" not in line)
    row = history.parse(older)
    assert row["ratio"] == "0.54 ×" and row["spin"] == "" and row["async"] == ""
