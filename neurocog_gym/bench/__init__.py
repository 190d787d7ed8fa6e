"""The obstacle benchmark of §6.5 (Tables 4–5): trial runner, outcome tally, report."""

from neurocog_gym.bench.outcome import (
    OUTCOMES,
    PAPER_TABLE4,
    PAPER_TABLE5,
    SCENARIOS,
    failure_analysis,
    scenario_summary,
    tally,
    wilson_interval,
)
from neurocog_gym.bench.records import load_trials
from neurocog_gym.bench.report import write_report
from neurocog_gym.bench.runner import (
    BenchConfig,
    BenchResult,
    SimilaritySettings,
    TrialSpec,
    run_benchmark,
    run_trial,
    trial_seed,
)

__all__ = [
    "OUTCOMES",
    "PAPER_TABLE4",
    "PAPER_TABLE5",
    "SCENARIOS",
    "BenchConfig",
    "BenchResult",
    "SimilaritySettings",
    "TrialSpec",
    "failure_analysis",
    "load_trials",
    "run_benchmark",
    "run_trial",
    "scenario_summary",
    "tally",
    "trial_seed",
    "wilson_interval",
    "write_report",
]
