"""Body variants (robot/variants.py): they compile, keep what they promise, and load as assets."""

from __future__ import annotations

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import neurocog_gym  # noqa: F401  (registers the envs)
from neurocog_gym import paths
from neurocog_gym.robot import names
from neurocog_gym.robot.variants import (
    KINKED_LOW,
    KINKED_PITCH,
    kinked_shank,
    knee_behind,
    write_assets,
)


def _geom(model, name):
    i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name)
    assert i >= 0, f"no geom {name}"
    return i


def _pose(model, hip: float, knee: float) -> mujoco.MjData:
    """Kinematics with every leg at (abduction 0, hip, knee), torso at the origin."""
    data = mujoco.MjData(model)
    data.qpos[:] = model.key("home").qpos
    for prefix in names.LEGS:
        data.joint(f"{prefix}_hip").qpos = hip
        data.joint(f"{prefix}_knee").qpos = knee
        data.joint(f"{prefix}_abduct").qpos = 0.0
    mujoco.mj_kinematics(model, data)
    return data


def test_kinked_shank_lower_segment_is_upright_at_its_pitch():
    base = mujoco.MjModel.from_xml_path(str(neurocog_gym.paths.asset("scene.xml")))
    spec = kinked_shank()
    model = spec.compile()
    assert model.ngeom == base.ngeom + 4
    # hip + knee = KINKED_PITCH (body v1's home pose: hip -0.8, knee 1.6).
    data = _pose(model, -KINKED_PITCH, 2 * KINKED_PITCH)
    for prefix in names.LEGS:
        low = _geom(model, f"{prefix}_shank_low")
        up = _geom(model, f"{prefix}_shank")
        foot = _geom(model, f"{prefix}_foot")
        axis = data.geom_xmat[low].reshape(3, 3)[:, 2]  # a capsule's axis is its local z
        assert abs(axis[2]) == pytest.approx(1.0, abs=1e-9)
        assert data.geom_xpos[low][:2] == pytest.approx(data.geom_xpos[foot][:2], abs=1e-9)
        assert model.geom_size[low][1] == pytest.approx(KINKED_LOW / 2)
        # the mass stays the shank's, split by length; same radius and collision bits
        body = f"{prefix}_shank"
        assert model.body(body).mass == pytest.approx(base.body(body).mass)
        m_up, m_low = spec.geom(f"{prefix}_shank").mass, spec.geom(f"{prefix}_shank_low").mass
        upper = 2 * model.geom_size[up][1]
        assert m_low / (m_up + m_low) == pytest.approx(KINKED_LOW / (KINKED_LOW + upper))
        assert model.geom_size[low][0] == model.geom_size[up][0]
        assert model.geom_group[low] == names.ROBOT_GEOM_GROUP
        assert (model.geom_contype[low], model.geom_conaffinity[low]) == (
            model.geom_contype[up],
            model.geom_conaffinity[up],
        )
    # the foot and the knee do not move: the legs' kinematics are body v1's
    data0 = _pose(base, -0.5, 1.2)
    data1 = _pose(model, -0.5, 1.2)
    for prefix in names.LEGS:
        f0 = data0.geom_xpos[_geom(base, f"{prefix}_foot")]
        f1 = data1.geom_xpos[_geom(model, f"{prefix}_foot")]
        assert f1 == pytest.approx(f0, abs=1e-12)


def test_kinked_shank_tilts_away_from_its_pitch():
    model = kinked_shank(pitch=0.8).compile()
    data = _pose(model, -0.5, 1.5)  # shank pitch 1.0: 0.2 rad past the design pitch
    axis = data.geom_xmat[_geom(model, "FL_shank_low")].reshape(3, 3)[:, 2]
    assert np.degrees(np.arccos(abs(axis[2]))) == pytest.approx(np.degrees(0.2), abs=1e-6)


@pytest.mark.parametrize(("low", "pitch"), [(0.0, 0.8), (0.2, 0.8), (0.1, 1.6), (-0.1, 0.0)])
def test_kinked_shank_rejects_bad_geometry(low, pitch):
    with pytest.raises(ValueError, match="low must|pitch must"):
        kinked_shank(low=low, pitch=pitch)


def test_knee_behind_keeps_each_foot_under_its_hip():
    model = knee_behind().compile()
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_kinematics(model, data)
    for prefix in names.LEGS:
        hip = data.body(f"{prefix}_thigh").xpos
        foot = data.geom_xpos[_geom(model, f"{prefix}_foot")]
        assert abs(foot[0] - hip[0]) < 0.02, prefix
        knee = data.body(f"{prefix}_shank").xpos
        assert knee[0] < foot[0], f"{prefix}: the knee must be behind the foot"


def test_kinked_assets_run_in_the_obstacle_env(tmp_path, monkeypatch):
    write_assets(kinked_shank(), tmp_path / "assets")
    monkeypatch.setenv("NEUROCOG_ASSETS", str(tmp_path / "assets"))
    with pytest.raises(ValueError, match="bent already"):  # body v2 bends the scene's shanks
        gym.make("NeuroCog/SuddenObstacle-v3")
    env = gym.make("NeuroCog/SuddenObstacle-v3", body="v1")  # the scene as written: bent
    try:
        u = env.unwrapped
        low = [_geom(u.model, f"{p}_shank_low") for p in names.LEGS]
        assert set(low) <= set(int(g) for g in u.robot.robot_geoms)
        env.reset(seed=0)
        for _ in range(20):
            _, _, terminated, truncated, info = env.step(np.zeros(15, np.float32))
            assert not (terminated or truncated)
        assert np.isfinite(info["x_position"])
    finally:
        env.close()


# -- the body keyword (robot.model.BODIES) ------------------------------------------------------


@pytest.mark.parametrize("env_id", neurocog_gym.ENV_IDS)
def test_every_env_takes_the_body(env_id):
    for body, has_low in (("v1", False), ("v2", True)):
        env = gym.make(env_id, body=body)
        try:
            u = env.unwrapped
            assert u.body == body
            low = mujoco.mj_name2id(u.model, mujoco.mjtObj.mjOBJ_GEOM, "FL_shank_low")
            assert (low >= 0) == has_low
            if has_low:
                assert low in set(int(g) for g in u.robot.robot_geoms)
        finally:
            env.close()
    with pytest.raises(ValueError, match="body must be one of"):
        gym.make(env_id, body="v3")


def test_body_v2_is_deterministic_and_differs_from_v1():
    def run(body):
        env = gym.make("NeuroCog/Walk-v3", body=body)
        env.reset(seed=3)
        xs = []
        for _ in range(150):
            obs, *_ = env.step(np.zeros(15, np.float32))
            xs.append(obs["joint_pos"].copy())
        env.close()
        return np.array(xs)

    a, b, c = run("v2"), run("v2"), run("v1")
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)  # the shank's mass moved: the walk is not bit-identical


def test_bend_shanks_refuses_a_bent_spec():
    spec = kinked_shank()
    from neurocog_gym.robot.variants import bend_shanks

    with pytest.raises(ValueError, match="bent already"):
        bend_shanks(spec)


def test_bench_takes_the_body(monkeypatch):
    from neurocog_gym import cli
    from neurocog_gym.bench import runner

    env = runner.make_env("sudden", "on", 0.1, body="v2")
    assert env.unwrapped.body == "v2"
    env.close()
    with pytest.raises(ValueError, match="body must be one of"):
        runner.BenchConfig(out="x", body="v3")
    cfg = runner.BenchConfig(out="x", body="v2")
    assert cfg.identity()["body"] == "v2"
    seen = {}

    def fake_run(cfg):
        seen["cfg"] = cfg
        raise RuntimeError("stop here")

    monkeypatch.setattr(runner, "run_benchmark", fake_run)
    rc = cli.main(["bench", "--scenario", "sudden", "--body", "v2", "--out", "unused"])
    assert rc == 2 and seen["cfg"].body == "v2"


def test_resume_reads_records_without_a_body_as_v1(tmp_path):
    from neurocog_gym.bench import runner

    cfg = runner.BenchConfig(out=tmp_path, resume=True, body="v1")
    old = {k: v for k, v in cfg.identity().items() if k != "body"}
    runner._check_resume(cfg, [old])  # a run from before the keyword: body v1
    with pytest.raises(ValueError, match="body"):
        runner._check_resume(runner.BenchConfig(out=tmp_path, resume=True), [old])  # v2


def test_nsga_configs_from_before_the_body_resume_on_v1():
    from neurocog_gym.train.evaluate import EvalParams
    from neurocog_gym.train.nsga import NSGAConfig

    cfg = NSGAConfig(pop_size=4, generations=1, eval=EvalParams(seconds=0.2))
    assert cfg.eval.body == "v2"
    raw = cfg.to_json()
    assert NSGAConfig.from_json(raw).eval.body == "v2"
    del raw["eval"]["body"]
    assert NSGAConfig.from_json(raw).eval.body == "v1"


def test_servo_speed_scales_the_velocity_gain_only():
    from neurocog_gym.robot.variants import servo_speed

    spec = mujoco.MjSpec.from_file(str(paths.asset(paths.SCENE_XML)))
    before = spec.compile()
    after = servo_speed(spec, 15.0).compile()
    stall = before.actuator_forcerange[:, 1]
    assert np.allclose(before.actuator_biasprm[:, 2], -0.91)  # the MX-64's 6 / 6.6
    assert np.allclose(after.actuator_biasprm[:, 2], -stall / 15.0)
    assert np.array_equal(after.actuator_biasprm[:, :2], before.actuator_biasprm[:, :2])
    assert np.array_equal(after.actuator_gainprm, before.actuator_gainprm)
    assert np.array_equal(after.actuator_forcerange, before.actuator_forcerange)
    with pytest.raises(ValueError, match="speed must be a positive"):
        servo_speed(spec, 0.0)


def test_gait_vel_max_reaches_the_pools(tmp_path):
    import dataclasses

    from neurocog_gym.locomotion.gait import Gait, default_gait
    from neurocog_gym.locomotion.generator import LocomotionGenerator

    shipped = default_gait()
    assert shipped.vel_max == 6.6  # a file without the field: the MX-64's speed
    fast = dataclasses.replace(shipped, vel_max=15.0)
    fast.save(tmp_path / "g.json")
    loaded = Gait.load(tmp_path / "g.json")
    assert loaded.vel_max == 15.0
    model = mujoco.MjModel.from_xml_path(str(paths.asset(paths.SCENE_XML)))
    lo, hi = model.jnt_range[1:, 0], model.jnt_range[1:, 1]
    gen = LocomotionGenerator(loaded, lo, hi)
    assert np.all(gen.pools.vel_max == 15.0)
    with pytest.raises(ValueError, match="vel_max must be a positive"):
        dataclasses.replace(shipped, vel_max=-1.0)


def test_written_assets_keep_body_v2s_shanks(tmp_path):
    # write_assets compiles the spec, so its capsules come back as pos / quat / size without
    # fromto; body v2's bend at load time must build the same shanks from them. Checked in a
    # fresh interpreter: there, before this fix, the bend read an unset fromto and left each
    # shank straight with its lower segment above the knee (a process that had compiled the
    # shipped scene first happened to get it right).
    import json
    import subprocess
    import sys

    from neurocog_gym.robot.model import load_model

    write_assets(mujoco.MjSpec.from_file(str(paths.asset(paths.SCENE_XML))), tmp_path)
    code = (
        "import json; from neurocog_gym.robot.model import load_model; m = load_model(body='v2');"
        "print(json.dumps({n: [m.geom(n).pos.tolist(), m.geom(n).size.tolist()] for n in "
        f"{[f'{p}_{part}' for p in names.LEGS for part in ('shank', 'shank_low')]!r}}}))"
    )
    env = {**__import__("os").environ, "NEUROCOG_ASSETS": str(tmp_path)}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    written = json.loads(out.stdout.strip().splitlines()[-1])
    shipped = load_model(body="v2")
    for name, (pos, size) in written.items():
        assert np.allclose(shipped.geom(name).pos, pos, atol=1e-6), (name, pos)
        assert np.allclose(shipped.geom(name).size, size, atol=1e-6), (name, size)
