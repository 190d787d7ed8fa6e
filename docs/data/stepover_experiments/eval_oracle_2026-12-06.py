"""Run OraclePolicy with given thresholds on benchmark trials (scratch, 2026-12-06; docs/oracle_notes.md).

    NEUROCOG_ASSETS=D python eval_oracle_2026-12-06.py N RUN_SEED '{json thresholds}' [REACH SWING [sudden|static]]
"""
import sys, json, collections
import numpy as np
from dataclasses import replace
from neurocog_gym.bench.runner import make_env, run_trial, TrialSpec, trial_seed
from neurocog_gym.policies.oracle import OraclePolicy, OracleParams
n, seed = int(sys.argv[1]), int(sys.argv[2])
params = json.loads(sys.argv[3]) if len(sys.argv) > 3 else {}
kw = {}
if len(sys.argv) > 5:
    from neurocog_gym.locomotion.effectivity import EffectivityParams
    kw["effectivity"] = EffectivityParams(reach=float(sys.argv[4]), swing_time=float(sys.argv[5]))
scen = sys.argv[6] if len(sys.argv) > 6 else "sudden"
env = make_env(scen, "on", None, privileged=True, env_kwargs=kw)
pol = OraclePolicy(replace(OracleParams(), **params))
c = collections.Counter()
for i in range(n):
    r = run_trial(env, pol, TrialSpec(scen, i, trial_seed(seed, scen, i)))
    c[r["outcome"]] += 1; c["passed"] += bool(r["passed"]); c["fell"] += bool(r["fell"])
    c["knocked"] += bool(r["knocked"]); c["stepped_over"] += bool(r["stepped_over"]); c["stood_on"] += bool(r["stood_on"])
    ev = (r.get("contacts") or {}).get("events") or []
    print(i, r["outcome"], str(r.get("contacts"))[:160], "passed" if r["passed"] else "", "FELL" if r["fell"] else "", "knock" if r["knocked"] else "", "over" if r["stepped_over"] else "", flush=True)
print(dict(c))
