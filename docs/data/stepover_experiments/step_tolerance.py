"""Fall tolerance of a tracked front-leg step (no block): Walk-v1, every 3rd FL and FR CPG swing onset."""
import sys, json, numpy as np, gymnasium as gym
sys.path.insert(0, "/tmp/x")
import neurocog_gym  # noqa
from oracle2 import ik, _rot_body, R_FOOT

def walk(seed, T, h, D, every=3, seconds=8.0, A=1300.0, tau_p=0.04, hold=True, legs=(0, 1)):
    env = gym.make("NeuroCog/SuddenObstacle-v1", privileged=True, appear_deadline=100.0) if False else gym.make("NeuroCog/Walk-v1")
    obs, _ = env.reset(seed=seed); u = env.unwrapped
    from neurocog_gym.robot import names
    prev_ref = None; sw_prev = np.zeros(4, bool); cnt = np.zeros(4, int)
    st = np.zeros(4, int); t = np.zeros(4); start = np.zeros((4, 3)); pdes = np.zeros((4, 2)); hasd = np.zeros(4, bool)
    fell = False; steps = 0; peak = []
    kb = u.robot.knee_behind
    for k in range(int(seconds / 0.01)):
        y = obs["cpg"].reshape(4, 6); srv = obs["servo_target"].astype(float)
        ref = srv.copy()
        for l in range(4):
            if kb[l]: ref[3*l+1] = srv[3*l+1] - srv[3*l+2]
        refd = np.zeros(12) if prev_ref is None else (ref - prev_ref) / 0.01
        prev_ref = ref
        sw = (y[:, 2] > y[:, 3]) | (y[:, 0] > y[:, 1])
        # feet / hips in the heading frame from the simulator (probe, not a policy)
        d = u.data
        torso = d.qpos[:3].copy()
        Rb_w = d.xmat[u.robot.torso_body].reshape(3, 3) if hasattr(u.robot, "torso_body") else None
        q = obs["torso_quat"]; Rb = _rot_body(q)
        w, x, yq, z = q; yaw = np.arctan2(2*(w*z + x*yq), 1 - 2*(yq*yq + z*z)); c, s = np.cos(yaw), np.sin(yaw)
        Rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        feet_w = d.site_xpos[u.robot.foot_site].copy()
        a = np.zeros(15, np.float32)
        for l in legs:
            if sw[l] and not sw_prev[l] and d.time > 2.0 and st[l] == 0:
                cnt[l] += 1
                if cnt[l] % every == 0:
                    st[l] = 1; t[l] = 0.0; start[l] = feet_w[l]; steps += 1; peak.append(0.0)
            if st[l] == 0:
                hasd[l] = False; continue
            t[l] += 0.01; tau = t[l] / T
            fwd = Rz[:, 0]
            if tau < 0.35: sx, sz = 0.0, h * min(1, tau / 0.35 * 1.3)
            elif tau < 0.7: sx, sz = D * (tau - 0.35) / 0.35, h
            else:
                f = min(1, (tau - 0.7) / 0.3); sx, sz = D + 0.02 * f, h * (1 - f) - 0.01 * f
            tgt_w = start[l] + fwd * sx; tgt_w[2] = R_FOOT + sz
            peak[-1] = max(peak[-1], feet_w[l, 2] - R_FOOT)
            # hip pitch joint in world: body position of the thigh
            hip_w = d.xpos[u.model.body(names.LEGS[l] + "_thigh").id]
            v_b = (Rz @ Rb).T @ (tgt_w - hip_w)
            hq, kq = ik(v_b); des = np.array([hq, kq])
            qd_des = (des - pdes[l]) / 0.01 if hasd[l] else np.zeros(2); pdes[l] = des; hasd[l] = True
            j = 3 * l
            qd_cmd = np.clip(qd_des + (des - ref[j+1:j+3]) / tau_p, -6.6, 6.6)
            v = refd[j+1:j+3]; dv = qd_cmd - v
            fv = np.maximum(np.where(np.sign(dv) == np.sign(v), (6.6 - np.abs(v)) / (6.6 + np.abs(v)), 1.2), 0.1)
            a[j+1:j+3] = np.clip(dv / (A * fv * 0.01), -1, 1)
            if (tau >= 1.0 and obs["touch"][l] > 0.05) or t[l] > 0.6:
                st[l] = 0
        if hold and any(st[l] and not sw[l] for l in legs):
            for o in range(4):
                if st[o] == 0 and sw[o]: a[3*o+1], a[3*o+2] = 0.3, -0.5
        sw_prev = sw
        obs, _, term, trunc, info = env.step(a)
        if term: fell = True; break
    env.close()
    return fell, steps, float(np.median(peak)) if peak else 0.0

if __name__ == "__main__":
    seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 6
    for T in (0.22, 0.26, 0.30, 0.34):
        for h in (0.06, 0.10):
            for D in (0.12, 0.20):
                r = [walk(s, T, h, D) for s in range(seeds)]
                print(f"T {T:.2f} apex {h*100:.0f} cm carry {D*100:.0f} cm: falls {sum(x[0] for x in r)} of {seeds}, steps {sum(x[1] for x in r)}, median peak {np.median([x[2] for x in r])*100:.1f} cm", flush=True)
