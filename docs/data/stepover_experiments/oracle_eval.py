"""Evaluate OraclePolicy(params) on n sudden trials with training seeds (not the bench's)."""
import sys, json, time, numpy as np
from dataclasses import replace
from neurocog_gym.bench.runner import make_env, run_trial, TrialSpec, trial_seed
from neurocog_gym.policies.oracle import OraclePolicy, OracleParams
from neurocog_gym.policies import start_episode

def evaluate(params=None, n=20, scenario="sudden", base=7777, verbose=False, policy=None):
    env = make_env(scenario, "on", None, privileged=True)
    pol = policy or OraclePolicy(params)
    recs = []
    for i in range(n):
        spec = TrialSpec(scenario, i, trial_seed(base, scenario, i))
        r = run_trial(env, pol, spec)
        recs.append(r)
        if verbose:
            print(i, r["outcome"], "knock", r["knocked"], "stood", r["stood_on"], "fell", r["fell"], "over", r["stepped_over"], "int", r["interrupt_cycles"], flush=True)
    env.close()
    c = {k: sum(r["outcome"] == k for r in recs) for k in ("success", "touch", "fail")}
    c["fell"] = sum(bool(r["fell"]) for r in recs); c["knocked"] = sum(bool(r["knocked"]) for r in recs)
    c["over"] = sum(bool(r["stepped_over"]) for r in recs)
    return c, recs

if __name__ == "__main__":
    t = time.time()
    kw = json.loads(sys.argv[1]) if len(sys.argv) > 1 else {}
    c, _ = evaluate(replace(OracleParams(), **kw), n=int(sys.argv[2]) if len(sys.argv) > 2 else 20, verbose=True)
    print(c, f"{time.time()-t:.0f}s")
