"""CMA-ES over Oracle2's parameters on 20 training sudden trials (seeds trial_seed(7777, ...))."""
import sys, json, time
sys.path.insert(0, "/tmp/x")
import numpy as np, cma
from dataclasses import replace
from oracle2 import Oracle2, P
from oeval import evaluate
# name: (lo, hi)
SPACE = {"clr": (0.01, 0.08), "margin": (0.02, 0.12), "lead": (0.04, 0.25), "carry_max": (0.08, 0.3),
         "T": (0.2, 0.4), "lift_hip": (-0.5, 0.8), "clr_ok": (0.0, 0.04), "over": (0.0, 0.06),
         "drop_back": (0.0, 0.1), "brake": (-1.0, 0.0), "hold_hip": (-0.5, 0.8), "hold_knee": (-1.0, 0.5),
         "max_over": (0.15, 0.4), "reach": (0.1, 0.35), "tau_p": (0.02, 0.08)}
names = list(SPACE)
def decode(x):
    return {n: float(SPACE[n][0] + (SPACE[n][1] - SPACE[n][0]) * np.clip(v, 0, 1)) for n, v in zip(names, x)}
def cost(x):
    kw = decode(x); kw["A"] = 1300.0
    c, recs = evaluate(replace(P(), **kw), n=20, policy=Oracle2(replace(P(), **kw)))
    return -(10 * (c["success"] + c["touch"]) + 5 * c["success"] + 3 * c["over"] - c["fell"] - 0.5 * c["knocked"]), c
p0 = P()
x0 = [(getattr(p0, n) - SPACE[n][0]) / (SPACE[n][1] - SPACE[n][0]) for n in names]
x0 = [min(max(v, 0.05), 0.95) for v in x0]
es = cma.CMAEvolutionStrategy(x0, 0.25, {"bounds": [0, 1], "seed": 1, "popsize": 10, "verbose": -9})
best = (1e9, None, None); t0 = time.time(); it = 0
while time.time() - t0 < float(sys.argv[1]):
    X = es.ask(); F = []
    for x in X:
        f, c = cost(x); F.append(f)
        if f < best[0]:
            best = (f, decode(x), c)
            print(f"{time.time()-t0:6.0f}s new best {f:.1f} {c} {json.dumps(best[1])}", flush=True)
    es.tell(X, F); it += 1
    print(f"{time.time()-t0:6.0f}s gen {it} median {np.median(F):.1f} best {best[0]:.1f}", flush=True)
json.dump({"best": best[1], "counts": best[2], "cost": best[0]}, open("/tmp/runs/cma_best.json", "w"), indent=1)
