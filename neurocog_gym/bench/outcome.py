"""Trial outcomes: the tally of Table 4, Wilson intervals, and the Table 5 failure analysis.

Outcome classes v1 (§6.5, SPEC §8; defined exactly, from MuJoCo contacts and poses, in
:mod:`neurocog_gym.envs.obstacle`, thresholds in
:class:`~neurocog_gym.envs.obstacle.OutcomeParams`):

* ``success``: passed the blocks and no robot geom ever touched one ("obstacle totally
  avoided").
* ``touch``: passed, touched, but never stood on a block and never knocked one ("avoided but
  touched").
* ``fail``: knocked a block (its centre moved more than 2 cm horizontally, or it turned more
  than 10° about any axis, from where it was placed), stood on a block (robot contacts on its
  top face, normal within 30° of up, carried at least 10 % of the robot's weight for 3 control
  cycles in a row), fell, the physics became unstable, or not passed when the time limit ran
  out. Climbing over a block is not avoiding it.

Each trial also records ``stepped_over``: every block was crossed above its footprint by at
least one front and one hind foot (not walked round).

The paper's counts (Table 4, a real robot, 50 trials each) are in :data:`PAPER_TABLE4`, its
failure analysis (Table 5) in :data:`PAPER_TABLE5`, its §6.2 latencies in
:data:`PAPER_LATENCY`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

import numpy as np

OUTCOMES: tuple[str, ...] = ("success", "touch", "fail")
SCENARIOS: tuple[str, ...] = ("sudden", "static")
STONE_SCENARIOS: tuple[str, ...] = ("stones", "stones-moving")
"""``NeuroCog/SteppingStones-v3`` still and moving: success = crossed without a foot in the pit,
fail = a foot in the pit, a fall, or not across in time (defined exactly in
:class:`neurocog_gym.envs.stones.SteppingStonesEnv`); ``touch`` is never given. The paper
reports no counts for them (no entry in :data:`PAPER_TABLE4`)."""

#: Table 4 (real robot): counts of success (never touched), success with touching, failed.
PAPER_TABLE4: dict[str, dict[str, int]] = {
    "sudden": {"trials": 50, "success": 28, "touch": 13, "fail": 9},
    "static": {"trials": 50, "success": 23, "touch": 21, "fail": 6},
}

#: Table 5 (real robot, failure analysis): averages over the success and the failure cases.
PAPER_TABLE5: dict[str, dict[str, float]] = {
    "success": {"best": 0.92, "time_to_best": 0.45, "at_0_5": 0.92},
    "fail": {"best": 0.89, "time_to_best": 0.75, "at_0_5": 0.48},
}

#: §6.2 and Fig. 10 (simulation, one trial), s after the sudden block appeared: the first
#: non-homogeneous nodes "0.1 s after obstacle was given", the accurate affordance "0.11 s
#: after" that, and the swing sent to the safe area "in this time" (our reading: at the
#: accurate affordance, 0.21 s).
PAPER_LATENCY: dict[str, float] = {
    "first_nonhomogeneous_s": 0.10,
    "accurate_s": 0.21,
    "first_interrupt_s": 0.21,
}

LATENCY_KEYS: tuple[str, ...] = ("first_nonhomogeneous_s", "accurate_s", "first_interrupt_s")
"""The §6.2 chain in a trial record's ``latency`` (``bench.runner.LatencyProbe``)."""

ACCURATE_WITHIN = 0.25
"""s: issue 23's latency target, an accurate affordance within this of the appearance."""

Z95 = 1.959963984540054
"""Two-sided 95 % standard normal quantile."""


def wilson_interval(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion ``k / n``.

    Args:
        k: successes, ``0 <= k <= n``.
        n: trials; ``n == 0`` gives the uninformative interval (0, 1).
        z: standard normal quantile (1.96 for 95 %).

    Returns:
        ``(low, high)``, both in [0, 1].
    """
    k, n = int(k), int(n)
    if n < 0 or not 0 <= k <= max(n, 0):
        raise ValueError(f"need 0 <= k <= n, got k={k}, n={n}")
    if n == 0:
        return 0.0, 1.0
    z2 = z * z
    centre = (k + z2 / 2) / (n + z2)
    half = z * math.sqrt(k * (n - k) / n + z2 / 4) / (n + z2)
    return max(0.0, centre - half), min(1.0, centre + half)


def tally(records: Iterable[Mapping]) -> dict:
    """Count the outcomes of one scenario's trial records and add rates with 95 % Wilson intervals.

    Args:
        records: trial records, each with an ``outcome`` in :data:`OUTCOMES`.

    Returns:
        ``{"trials", "success", "touch", "fail", "success_rate", "success_or_touch_rate",
        "fail_rate", "wilson95": {"success": [lo, hi], "success_or_touch": [...],
        "fail": [...]}}``; rates are None when there are no trials.
    """
    counts = dict.fromkeys(OUTCOMES, 0)
    for r in records:
        o = r["outcome"]
        if o not in counts:
            raise ValueError(f"unknown outcome {o!r} (expected one of {OUTCOMES})")
        counts[o] += 1
    n = sum(counts.values())
    passed = counts["success"] + counts["touch"]

    def rate(k: int) -> float | None:
        return k / n if n else None

    return {
        "trials": n,
        **counts,
        "success_rate": rate(counts["success"]),
        "success_or_touch_rate": rate(passed),
        "fail_rate": rate(counts["fail"]),
        "wilson95": {
            "success": list(wilson_interval(counts["success"], n)),
            "success_or_touch": list(wilson_interval(passed, n)),
            "fail": list(wilson_interval(counts["fail"], n)),
        },
    }


def _mean(values: list) -> float | None:
    v = [float(x) for x in values if x is not None and np.isfinite(x)]
    return float(np.mean(v)) if v else None


def failure_analysis(records: Iterable[Mapping]) -> dict:
    """Table 5 quantities averaged over the passed (success or touch) and the failed trials.

    Each record's ``similarity`` holds ``best`` (highest μ), ``time_to_best`` (s after the
    obstacle appeared or came into view) and ``at_0_5`` (μ 0.5 s after it); missing values
    (no similarity measured, trial ended before 0.5 s) are left out of the means.

    Returns:
        ``{"success": {"n", "best", "time_to_best", "at_0_5"}, "fail": {...}}`` where
        ``success`` groups both passed outcomes as the paper's success case does; means are None
        when no trial of the group has the value.
    """
    groups: dict[str, list[Mapping]] = {"success": [], "fail": []}
    for r in records:
        groups["fail" if r["outcome"] == "fail" else "success"].append(r.get("similarity") or {})
    out = {}
    for name, sims in groups.items():
        out[name] = {
            "n": len(sims),
            "best": _mean([s.get("best") for s in sims]),
            "time_to_best": _mean([s.get("time_to_best") for s in sims]),
            "at_0_5": _mean([s.get("at_0_5") for s in sims]),
        }
    return out


def similarity_by_outcome(records: Iterable[Mapping]) -> dict:
    """Table 5's three measures averaged over each outcome apart (success, touch, fail).

    As :func:`failure_analysis`, but touch is a group of its own instead of joining success.

    Returns:
        ``{"success": {"n", "best", "time_to_best", "at_0_5"}, "touch": {...}, "fail": {...}}``;
        ``n`` counts the trials of the outcome, the means leave out missing values (None when
        no trial of the outcome has one).
    """
    groups: dict[str, list[Mapping]] = {o: [] for o in OUTCOMES}
    for r in records:
        groups[r["outcome"]].append(r.get("similarity") or {})
    return {
        name: {
            "n": len(sims),
            "best": _mean([s.get("best") for s in sims]),
            "time_to_best": _mean([s.get("time_to_best") for s in sims]),
            "at_0_5": _mean([s.get("at_0_5") for s in sims]),
        }
        for name, sims in groups.items()
    }


def _quantile(v: np.ndarray, q: float) -> float:
    """The q-quantile of ``v`` (linear, NumPy's default), ``inf`` counting as never.

    A quantile that falls on or between a never is never (``np.quantile`` gives NaN at
    inf * 0).
    """
    if len(v) == 0:
        return math.inf
    v = np.sort(v)
    pos = q * (len(v) - 1)
    lo, hi = int(math.floor(pos)), int(math.ceil(pos))
    if not math.isfinite(v[hi]):
        return math.inf
    return float(v[lo] + (v[hi] - v[lo]) * (pos - lo))


def latency_summary(records: Iterable[Mapping], within: float = ACCURATE_WITHIN) -> dict:
    """The §6.2 chain over the trials that carry a ``latency`` (sudden trials).

    A trial in which an event never happened counts as infinitely late, so the median is the
    time by which half the trials had the event (None when fewer than half had it at all);
    the quartiles likewise.

    Args:
        records: trial records; those without a ``latency`` (static, older runs) are left out.
        within: s, the window of ``accurate_within``.

    Returns:
        ``{"n", "accurate_within": share of trials with an accurate affordance at most
        ``within`` s after the appearance, "accurate_within_ci": its 95 % Wilson interval
        [lo, hi], "within": within, and per key of :data:`LATENCY_KEYS` and
        ``"first_frame_s"`` (the first sensor frame on the block) {"median", "q1",
        "q3" (s; None: never), "happened" (trials with the event)}}``; shares are None when
        ``n`` is 0.
    """
    lats = [r["latency"] for r in records if r.get("latency")]
    n = len(lats)
    out: dict = {"n": n, "within": within}
    for key in (*LATENCY_KEYS, "first_frame_s"):
        v = np.array([math.inf if x.get(key) is None else float(x[key]) for x in lats])
        q1, med, q3 = (_quantile(v, q) for q in (0.25, 0.5, 0.75))
        out[key] = {
            "median": med if math.isfinite(med) else None,
            "q1": q1 if math.isfinite(q1) else None,
            "q3": q3 if math.isfinite(q3) else None,
            "happened": int(np.isfinite(v).sum()),
        }
    acc = [x.get("accurate_s") for x in lats]
    k = sum(a is not None and a <= within + 1e-9 for a in acc)
    out["accurate_within"] = k / n if n else None
    out["accurate_within_ci"] = list(wilson_interval(k, n)) if n else None
    return out


def latency_by_outcome(records: Iterable[Mapping], within: float = ACCURATE_WITHIN) -> dict:
    """:func:`latency_summary` over all trials (``"all"``) and over each outcome apart."""
    records = list(records)
    out = {"all": latency_summary(records, within)}
    for o in OUTCOMES:
        out[o] = latency_summary([r for r in records if r["outcome"] == o], within)
    return out


def scenario_summary(records: Iterable[Mapping]) -> dict:
    """Everything ``summary.json`` says about one scenario: the tally plus means and Table 5."""
    records = list(records)
    out = tally(records)
    passed = [r for r in records if r["outcome"] != "fail"]
    out["mean_time_to_pass_s"] = _mean([r.get("time_to_pass") for r in passed])
    out["mean_touch_events"] = _mean([r.get("touch_events") for r in records])
    # v1 outcome parts (records written before v1 lack them and count as False).
    out["knocked"] = sum(bool(r.get("knocked")) for r in records)
    out["stood_on"] = sum(bool(r.get("stood_on")) for r in records)
    out["stepped_over"] = sum(bool(r.get("stepped_over")) for r in records)
    out["falls"] = sum(bool(r.get("fell")) for r in records)
    out["sim_unstable"] = sum(bool(r.get("sim_unstable")) for r in records)
    out["perception_ms_mean"] = _mean([(r.get("perception_ms") or {}).get("mean") for r in records])
    out["perception_ms_max"] = max(
        [(r.get("perception_ms") or {}).get("max") or 0.0 for r in records], default=None
    )
    out["failure_analysis"] = failure_analysis(records)
    out["similarity_by_outcome"] = similarity_by_outcome(records)
    out["latency"] = latency_by_outcome(records)
    return out
