import sys, json, numpy as np, mujoco
from dataclasses import replace
from neurocog_gym.bench.runner import make_env, TrialSpec, trial_seed
from neurocog_gym.policies.oracle import OraclePolicy, OracleParams, _in_block
from neurocog_gym.policies import start_episode
from scipy.spatial.transform import Rotation as R
i = int(sys.argv[1]); kw = json.loads(sys.argv[2]) if len(sys.argv) > 2 else {}
sys.path.insert(0, "/tmp/x")
import oracle2
env = make_env("sudden", "on", None, privileged=True); pol = oracle2.Oracle2(replace(oracle2.P(), **kw)) if "--o2" in sys.argv else OraclePolicy(replace(OracleParams(), **kw))
obs, info = env.reset(seed=trial_seed(7777, "sudden", i)); start_episode(pol, env)
u = env.unwrapped; m, d = u.model, u.data
names = lambda g: mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g)
seen=set(); t_app=None
for k in range(700):
    a = pol(obs)
    obs, r, term, trunc, info = env.step(a)
    b = np.asarray(obs["true_blocks"]).reshape(-1, 7)
    act = b[b[:, 0] != 0]
    if len(act) and t_app is None: t_app = d.time; print("appear", round(d.time,2), "blocks", np.round(act,3).tolist())
    if t_app is None: continue
    feet = np.asarray(obs["feet"]).reshape(4, 3)
    q = obs["torso_quat"]; eul = R.from_quat([q[1], q[2], q[3], q[0]]).as_euler("xyz", degrees=True)
    bb = act[0]
    rel = [(_in_block(feet[l, :2], bb)[0] + bb[4]) * 100 for l in range(4)]  # from near face, cm
    cons = []
    for c in d.contact[: d.ncon]:
        n1, n2 = names(c.geom1) or "", names(c.geom2) or ""
        if "block" in n1 or "block" in n2 or "obst" in n1 or "obst" in n2:
            cons.append(n1 + "/" + n2)
    if True:
        print(f"{d.time:5.2f} st{pol.state.tolist()} roll{eul[0]:6.1f} pit{eul[1]:6.1f} h{obs['torso_height'][0]:.3f} sole" +
              " ".join(f"{(feet[l,2]-0.018)*100:5.1f}" for l in range(4)) + " xnear " + " ".join(f"{v:6.1f}" for v in rel) + " " + ",".join(cons))
    if term or trunc or d.time - t_app > 1.5: print("end", info.get("outcome"), term, trunc); break
