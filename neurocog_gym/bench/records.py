"""The trial records of a benchmark run folder (``trials.jsonl``), read back.

:mod:`neurocog_gym.bench.runner` writes the file and :mod:`neurocog_gym.bench.report` reads
it; both import the reader from here, so the report never imports the runner.
"""

from __future__ import annotations

import os
from pathlib import Path

from neurocog_gym import io


def load_trials(out: str | os.PathLike) -> list[dict]:
    """Finished trial records of a run folder, first record per (scenario, index) kept."""
    seen, records = set(), []
    for r in io.read_jsonl(Path(out) / "trials.jsonl"):
        key = (r.get("scenario"), r.get("index"))
        if key not in seen:
            seen.add(key)
            records.append(r)
    return records
