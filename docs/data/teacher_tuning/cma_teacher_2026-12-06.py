"""CMA-ES over the AEF's stop / side-step / pass teacher on v3 sudden training trials (scratch).

The teacher's numbers (``locomotion.avoidance.AvoidanceParams``) were chosen on the v0-v2 trots;
the v3 trot (roll reflex on) answers the walking provision differently. Each candidate runs the
AEF (shipped network, fit with the candidate teacher) on the sudden training trials
``trial_seed(7777, "sudden", i)``, i < N, which the benchmark never runs; cost -(2 success +
touch - 2 falls).

    python cma_teacher_2026-12-06.py N OUT.json GENERATIONS
"""

import json
import multiprocessing as mp
import sys
from dataclasses import replace

import cma
import numpy as np

SPACE = {  # name: (lo, hi); the start is the shipped value
    "trigger": (0.2, 0.5),
    "margin": (0.0, 0.06),
    "t_rev": (0.0, 0.6),
    "backoff": (0.0, 0.15),
    "k_side": (0.4, 1.0),
    "kx": (0.0, 20.0),
    "side_backoff": (0.02, 0.12),
    "k_min": (0.4, 1.0),
    "side_dir": (0.0, 4.0),
    "side_dir_ff": (0.0, 1.0),
    "cor_gain": (2.0, 20.0),
    "lane_hysteresis": (0.0, 0.04),
}
NAMES = list(SPACE)
LO = np.array([SPACE[k][0] for k in NAMES])
HI = np.array([SPACE[k][1] for k in NAMES])
N = int(sys.argv[1])


def params_of(x):
    """The teacher's numbers of a point of the unit cube."""
    v = LO + (HI - LO) * np.clip(x, 0, 1)
    return {k: float(a) for k, a in zip(NAMES, v, strict=False)}


_env = None


def evaluate(x):
    """(success, touch, falls) of the AEF with the teacher at ``x`` on the first N trials."""
    global _env
    from neurocog_gym.bench.runner import TrialSpec, make_env, run_trial, trial_seed
    from neurocog_gym.locomotion.avoidance import AvoidanceParams
    from neurocog_gym.locomotion.fit import FitParams
    from neurocog_gym.policies.aef import AEFPolicy

    if _env is None:
        _env = make_env("sudden", "on", None)
    pol = AEFPolicy(fit=FitParams(avoidance=replace(AvoidanceParams(), **params_of(x))))
    s = t = f = 0
    for i in range(N):
        r = run_trial(_env, pol, TrialSpec("sudden", i, trial_seed(7777, "sudden", i)))
        s += r["outcome"] == "success"
        t += r["outcome"] == "touch"
        f += bool(r["fell"])
    return s, t, f


if __name__ == "__main__":
    from neurocog_gym.locomotion.avoidance import AvoidanceParams

    out, gens = sys.argv[2], int(sys.argv[3])
    base = AvoidanceParams()
    x0 = np.clip((np.array([getattr(base, k) for k in NAMES]) - LO) / (HI - LO), 0, 1)
    es = cma.CMAEvolutionStrategy(
        x0, 0.12, {"popsize": 8, "bounds": [0, 1], "seed": 5, "verbose": -9}
    )
    best = None
    with mp.Pool(2) as pool:
        start = evaluate(x0)
        print("start", start, flush=True)
        for g in range(gens):
            xs = es.ask()
            res = pool.map(evaluate, xs)
            fs = [-(2 * s + t - 2 * f) for s, t, f in res]
            es.tell(xs, fs)
            for x, r, fv in zip(xs, res, fs, strict=False):
                if best is None or fv < best[0]:
                    best = (fv, params_of(x), r)
                    json.dump(
                        {
                            "score": -fv,
                            "success": r[0],
                            "touch": r[1],
                            "fell": r[2],
                            "start": start,
                            "params": best[1],
                        },
                        open(out, "w"),
                        indent=1,
                    )
            print(g, "gen best", min(fs), "overall", best[0], best[2], flush=True)
