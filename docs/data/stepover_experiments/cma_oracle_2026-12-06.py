"""CMA-ES over OraclePolicy thresholds on sudden training trials (scratch, 2026-12-06).

    NEUROCOG_ASSETS=D python cma_oracle_2026-12-06.py N_TRIALS RUN_SEED OUT.json GENERATIONS [START.json [perceived]]

START.json: start from its "params" (an earlier OUT.json) instead of SPACE's starts; "perceived":
the script reads ``remembered_blocks`` (the env's perceived, remembered boxes) in place of
``true_blocks``, how far the step-over gets on what the robot perceives.
"""
import sys, json, numpy as np, cma, multiprocessing as mp
from dataclasses import replace
SPACE = {  # name: (lo, hi, start)
    "fresh_swing": (0.03, 0.30, 0.22), "brake_sag": (-0.6, 0.0, -0.05), "drop_gap": (0.01, 0.08, 0.04),
    "clearance": (0.01, 0.06, 0.03), "beyond": (0.0, 0.08, 0.03), "lift_hip": (-0.6, 0.6, 0.3),
    "carry_knee": (-0.5, 1.0, 0.5), "carry_gain": (0.0, 40.0, 20.0), "land_hip": (-0.5, 0.5, 0.0),
    "land_knee": (-1.0, 0.0, -1.0), "max_over": (0.10, 0.30, 0.20), "trigger": (0.0, 0.08, 0.04),
    "lane_margin": (0.0, 0.06, 0.03), "max_hold": (0.3, 0.8, 0.45), "hold_hip": (-0.5, 0.5, 0.3),
    "hold_knee": (-1.0, 0.0, -0.5),
}
NAMES = list(SPACE); LO = np.array([SPACE[k][0] for k in NAMES]); HI = np.array([SPACE[k][1] for k in NAMES])
START = json.load(open(sys.argv[5]))["params"] if len(sys.argv) > 5 else {k: v[2] for k, v in SPACE.items()}
X0 = np.clip((np.array([START[k] for k in NAMES]) - LO) / (HI - LO), 0, 1)
PERCEIVED = len(sys.argv) > 6 and sys.argv[6] == "perceived"
N, SEED = int(sys.argv[1]), int(sys.argv[2])
_env = None
def params_of(x):
    v = LO + (HI - LO) * np.clip(x, 0, 1)
    return {k: float(val) for k, val in zip(NAMES, v)}
def evaluate(x):
    global _env
    from neurocog_gym.bench.runner import make_env, run_trial, TrialSpec, trial_seed
    from neurocog_gym.policies.oracle import OraclePolicy, OracleParams
    from neurocog_gym.locomotion.effectivity import EffectivityParams
    if _env is None:
        _env = make_env("sudden", "on", None, privileged=True,
                        env_kwargs={"effectivity": EffectivityParams(reach=0.06, swing_time=0.27)})
    class Perceived(OraclePolicy):
        def __call__(self, obs):
            obs = dict(obs)
            obs["true_blocks"] = obs["remembered_blocks"]
            return super().__call__(obs)

    pol = (Perceived if PERCEIVED else OraclePolicy)(replace(OracleParams(), **params_of(x)))
    s = t = f = 0
    for i in range(N):
        r = run_trial(_env, pol, TrialSpec("sudden", i, trial_seed(SEED, "sudden", i)))
        s += r["outcome"] == "success"; t += r["outcome"] == "touch"; f += bool(r["fell"])
    return s, t, f
if __name__ == "__main__":
    out = sys.argv[3]; gens = int(sys.argv[4])
    es = cma.CMAEvolutionStrategy(X0, 0.15, {"popsize": 10, "bounds": [0, 1], "seed": 3, "verbose": -9})
    best = None
    with mp.Pool(2) as pool:
        for g in range(gens):
            xs = es.ask()
            res = pool.map(evaluate, xs)
            fs = [-(s + 0.5 * t - 0.2 * f) for s, t, f in res]
            es.tell(xs, fs)
            for x, (s, t, f), fv in zip(xs, res, fs):
                if best is None or fv < best[0]:
                    best = (fv, params_of(x), (s, t, f))
                    json.dump({"score": -fv, "success": s, "touch": t, "fell": f, "params": best[1]}, open(out, "w"), indent=1)
            print(g, "gen best", min(fs), "overall", best[0], best[2], flush=True)
