import sys, numpy as np, mujoco
sys.path.insert(0, "/work/main")
from neurocog_gym import paths
from neurocog_gym.robot import names
from neurocog_gym.robot.variants import write_assets

def kinked(d=0.10, theta0=0.8, spec=None):
    spec = spec or mujoco.MjSpec.from_file(str(paths.asset(paths.SCENE_XML)))
    K = np.array([-d * np.sin(theta0), 0.0, -0.2 + d * np.cos(theta0)])
    up = np.linalg.norm(K); low = d
    for prefix in names.LEGS:
        g = spec.geom(f"{prefix}_shank")
        body = g.parent
        m = g.mass
        g.fromto = [0, 0, 0, *K]
        g.mass = m * up / (up + low)
        g2 = body.add_geom()
        g2.name = f"{prefix}_shank_low"
        g2.type = mujoco.mjtGeom.mjGEOM_CAPSULE
        g2.size = g.size
        g2.fromto = [*K, 0, 0, -0.2]
        g2.mass = m * low / (up + low)
        g2.rgba = g.rgba
        g2.group = g.group
        g2.contype = g.contype; g2.conaffinity = g.conaffinity
        g2.condim = g.condim
    return spec

if __name__ == "__main__":
    d = float(sys.argv[2]); th = float(sys.argv[3])
    write_assets(kinked(d, th), sys.argv[1])
