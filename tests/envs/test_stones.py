"""NeuroCog/SteppingStones-v3 (neurocog_gym/envs/stones.py, robot/stones.py): course, outcome,
observation, determinism, errors, benchmark scenarios.

The registered id also runs through the parametrized checks of test_conformance.py,
tests/reliability and tests/ecosystem (it is in ``neurocog_gym.ENV_IDS``).
"""

import math
import warnings
from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import neurocog_gym  # noqa: F401
from neurocog_gym.envs.stones import STONE_FIELDS, SupportParams, perceived_support
from neurocog_gym.robot.stones import (
    CLEARANCE,
    Course,
    CourseParams,
    Stone,
    draw_course,
)

STONES = "NeuroCog/SteppingStones-v3"
ZERO = np.zeros(15, np.float32)
# Rows of touching 25 cm stones under both tracks: no gap anywhere, the blind trot crosses.
GAPLESS = CourseParams(gap=(0.0, 0.0), lateral=0.0, stone_size=(0.25, 0.25))


@pytest.fixture(scope="module")
def env():
    e = gym.make(STONES)
    yield e
    e.close()


def _run(env, seed, steps=1500, policy=None):
    obs, info = env.reset(seed=seed)
    for t in range(steps):
        obs, r, term, trunc, info = env.step(ZERO if policy is None else policy(obs))
        if term or trunc:
            return t + 1, term, trunc, info
    return steps, False, False, info


# -- conformance ---------------------------------------------------------------------------


ACCEPTED = {
    "A Box observation space maximum value is infinity. This is probably too high.",
    "A Box observation space minimum value is -infinity. This is probably too low.",
}


@pytest.mark.parametrize("kwargs", [{"moving": True}, {"privileged": True, "moving": True}])
def test_gymnasium_env_checker(kwargs):
    env = gym.make(STONES, **kwargs)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped, skip_render_check=True)
    env.close()
    texts = {str(w.message).replace("\x1b[33mWARN: ", "").replace("\x1b[0m", "") for w in caught}
    assert not texts - ACCEPTED


@pytest.mark.parametrize(
    "kwargs", [{}, {"moving": True}, {"privileged": True}, {"observation_mode": "depth_only"}]
)
def test_sb3_check_env_is_silent(kwargs, check_env_silently):
    check_env_silently(gym.make(STONES, **kwargs))


def test_observation_keys_are_the_obstacle_envs_plus_support():
    stones = gym.make(STONES, privileged=True)
    static = gym.make("NeuroCog/StaticObstacle-v3", privileged=True)
    s, o = set(stones.observation_space.spaces), set(static.observation_space.spaces)
    assert s - o == {"foothold_supported", "true_stones"} and o <= s
    assert stones.action_space == static.action_space
    assert stones.observation_space["true_stones"].shape == (24 * len(STONE_FIELDS),)
    assert "true_stones" not in gym.make(STONES).observation_space.spaces
    depth_only = gym.make(STONES, observation_mode="depth_only").observation_space.spaces
    assert "foothold_supported" not in depth_only and "foothold" not in depth_only
    for e in (stones, static):
        e.close()


@pytest.mark.parametrize("moving", [False, True])
def test_same_seed_same_episode_bit_for_bit(moving):
    env = gym.make(STONES, moving=moving, privileged=True)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-0.3, 0.3, (150, 15)).astype(np.float32)

    def episode(seed):
        obs, _ = env.reset(seed=seed)
        trace = [obs]
        for a in actions:
            obs, r, term, trunc, info = env.step(a)
            trace.append({**obs, "r": np.float64(r)})
            if term or trunc:
                break
        return trace, env.unwrapped.data.qpos.copy(), info["course"]

    t1, q1, c1 = episode(11)
    t2, q2, c2 = episode(11)
    assert c1 == c2 and np.array_equal(q1, q2) and len(t1) == len(t2)
    for a, b in zip(t1, t2, strict=True):
        assert a.keys() == b.keys()
        assert all(np.array_equal(a[k], b[k]) for k in a)
    _, _, c3 = episode(12)
    assert c3 != c1
    env.close()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"moving": "yes"}, "moving must be True or False"),
        ({"pit_depth": -0.1}, "pit_depth must be in"),
        ({"pit_tolerance": 0.3}, "pit_tolerance must be in"),
        ({"course": {"gap": (0.1, 0.2)}}, "course must be a CourseParams"),
        ({"support": 3}, "support must be a SupportParams"),
    ],
)
def test_bad_keyword_is_a_clear_error(kwargs, match):
    with pytest.raises(ValueError, match=match):
        gym.make(STONES, **kwargs)


def test_unknown_keyword_is_named():
    with pytest.raises(TypeError, match="bogus"):
        gym.make(STONES, bogus=1)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"gap": (0.2, 0.1)}, "gap must be"),
        ({"stone_size": (0.0, 0.2)}, "stone_size must be positive"),
        ({"lateral": -1.0}, "lateral must be"),
    ],
)
def test_bad_course_params(kwargs, match):
    with pytest.raises(ValueError, match=match):
        CourseParams(**kwargs)


def test_course_too_long_for_the_slots_is_refused():
    with pytest.raises(ValueError, match="slots"):
        draw_course(np.random.default_rng(0), CourseParams(course_length=(6.0, 6.0)), 0.2)


# -- the course ----------------------------------------------------------------------------


def test_courses_have_the_documented_figures():
    p = CourseParams()
    for seed in range(50):
        c = draw_course(np.random.default_rng(seed), p, front_x=0.19)
        assert 0.19 + 0.25 <= c.start_edge <= 0.19 + 0.5
        for side in (1.0, -1.0):
            row = sorted((s for s in c.stones if np.sign(s.y) == side), key=lambda s: s.x)
            assert len(row) >= 3
            edges = [c.start_edge]
            for s in row:
                assert 0.12 <= s.length <= 0.25 and 0.12 <= s.width <= 0.25
                assert abs(s.y - side * 0.12) <= 0.04 + 1e-12
                assert s.speed == 0.0
                edges += [s.x - s.length / 2, s.x + s.length / 2]
            gaps = np.diff(edges)[0::2]  # start edge -> first stone, stone -> next stone
            assert np.all((gaps >= 0.05 - 1e-12) & (gaps <= 0.15 + 1e-12))
            # the last stone starts within the course length (at most 1.5 m); the next one
            # would have started past it (at least 1.0 m), a gap of at most 15 cm on
            assert row[-1].x - row[-1].length / 2 - c.start_edge < 1.5
            assert row[-1].x + row[-1].length / 2 - c.start_edge >= 1.0 - 0.15
        last = max(s.x + s.length / 2 for s in c.stones)
        assert 0.05 - 1e-12 <= c.end_edge - last <= 0.15 + 1e-12


def test_the_course_is_placed_in_the_scene_without_rebuilding_it(env):
    u = env.unwrapped
    model = u.model
    env.reset(seed=3)
    first = u.course
    env.reset(seed=4)
    assert u.model is model and u.course != first
    m, d = u.model, u.data
    boxes = u.stones.boxes(d)
    assert len(boxes) == 2 + len(u.course.stones)
    # every top is the walking surface, every bottom just above the pit floor
    assert np.allclose(boxes[:, 1, 2], 0.0) and np.allclose(boxes[:, 0, 2], -0.25 + CLEARANCE)
    assert math.isclose(d.geom_xpos[m.geom("floor").id][2], -0.25)
    for k, s in enumerate(u.course.stones):
        g = u.stones.geom_ids[k + 2]
        assert np.allclose(d.geom_xpos[g][:2], (s.x, s.y))
        assert np.allclose(m.geom_size[g][:2], (s.length / 2, s.width / 2))
    assert math.isclose(boxes[0, 1, 0], u.course.start_edge)
    assert math.isclose(boxes[1, 0, 0], u.course.end_edge)
    # the unused slots are parked: no collisions, out of the way
    for g in u.stones.geom_ids[2 + len(u.course.stones) :]:
        assert m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0 and d.geom_xpos[g][2] < -1


def test_the_robot_stands_on_the_start_platform(env):
    """Its feet are ~0.6 m from the platform box's centre, beyond the 5 cm box it was compiled
    with: the broad phase must see the run-time size (the BVH box), or the feet sink."""
    u = env.unwrapped
    env.reset(seed=0)
    for _ in range(30):
        obs, r, term, trunc, info = env.step(ZERO)
    assert not term and not info["in_pit"]
    assert np.all(u._feet()[:, 2] > -0.005)


def test_moving_stones_slide_sideways_within_their_range():
    env = gym.make(STONES, moving=True)
    u = env.unwrapped
    env.reset(seed=5)
    stones = u.course.stones
    assert all(0.02 <= s.speed <= 0.05 and s.amplitude == 0.05 for s in stones)
    ids = u.stones.geom_ids[2 : 2 + len(stones)]
    y0 = u.data.geom_xpos[ids, 1].copy()
    x0 = u.data.geom_xpos[ids, 0].copy()
    ys = []
    for _ in range(100):
        env.step(ZERO)
        ys.append(u.data.geom_xpos[ids, 1].copy())
    ys = np.array(ys)
    placed = np.array([s.y for s in stones])
    assert np.all(np.abs(ys - placed) <= 0.05 + 1e-9)
    speed = np.abs(np.diff(ys, axis=0)) / u.dt
    assert np.all(speed <= 0.05 + 1e-9) and np.all(speed.max(axis=0) >= 0.02 - 1e-9)
    assert not np.allclose(ys[-1], y0) and np.array_equal(u.data.geom_xpos[ids, 0], x0)
    env.close()


def test_stone_triangle_wave():
    s = Stone(0.0, 0.1, 0.2, 0.2, speed=0.02, amplitude=0.05, phase=0.0)
    # 0.02 m/s: +5 cm at 2.5 s, back through 0 at 5 s to -5 cm at 7.5 s, home at 10 s
    for t, y in [(0.0, 0.1), (2.5, 0.15), (5.0, 0.1), (7.5, 0.05), (10.0, 0.1), (1.0, 0.12)]:
        assert math.isclose(s.y_at(t), y, abs_tol=1e-12)
    assert s.vy_at(1.0) == 0.02 and s.vy_at(3.0) == -0.02 and s.vy_at(8.0) == 0.02
    assert Stone(0.0, 0.1, 0.2, 0.2).y_at(3.0) == 0.1


# -- the outcome (staged) ------------------------------------------------------------------


def _stage(env, course: Course, seed=0):
    """Reset, then replace the drawn course by ``course`` (the robot at its reset pose)."""
    import mujoco

    u = env.unwrapped
    env.reset(seed=seed)
    u.course = course
    u.stones.place(u.model, u.data, course)
    mujoco.mj_forward(u.model, u.data)
    return u


def _home_feet(env):
    u = env.unwrapped
    env.reset(seed=0)
    return u._feet().copy()


def _steps(env, n):
    for t in range(n):
        obs, r, term, trunc, info = env.step(ZERO)
        if term or trunc:
            return t + 1, term, trunc, info
    return n, False, False, info


def test_a_foot_over_a_gap_goes_into_the_pit_and_fails(env):
    feet = _home_feet(env)
    fl, fr = feet[0], feet[1]
    # The start platform ends between the hind and the front feet; a stone carries FR only,
    # the front-left foot stands over the pit.
    course = Course(0.0, 3.0, (Stone(fr[0], fr[1], 0.2, 0.2),))
    _stage(env, course)
    n, term, trunc, info = _steps(env, 200)
    assert term and not trunc
    assert info["in_pit"] and info["pit_leg"] == 0 and info["outcome"] == "fail"
    assert not info["crossed"] and not info["fell"]
    assert env.unwrapped._feet()[0, 2] < -0.02
    # the same stance with a stone under FL too: no foot enters the pit
    course = Course(0.0, 3.0, (Stone(fl[0], fl[1], 0.2, 0.2), Stone(fr[0], fr[1], 0.2, 0.2)))
    _stage(env, course)
    u = env.unwrapped
    for _ in range(20):
        mujoco_step_hold(u)
    assert not u.in_pit and u._feet()[:, 2].min() > -0.005


def mujoco_step_hold(u):
    """One control cycle of the home pose held by the servos (no CPG: the robot stands)."""
    import mujoco

    u.data.ctrl[u.robot.actuator] = u.robot.home_qpos[u.robot.qpos_adr]
    mujoco.mj_step(u.model, u.data, nstep=u.frame_skip)
    u._after_physics()


def test_crossing_a_gapless_course_is_success():
    env = gym.make(STONES, course=GAPLESS)
    n, term, trunc, info = _run(env, seed=1)
    u = env.unwrapped
    assert term and info["outcome"] == "success" and info["crossed"] and not info["in_pit"]
    assert u._feet()[:, 0].min() > u.course.end_edge + u.pass_margin
    assert info["reward_pass"] == 100.0
    env.close()


def test_not_across_in_time_is_fail():
    env = gym.make(STONES, course=GAPLESS, max_episode_steps=100)
    n, term, trunc, info = _run(env, seed=1)
    assert trunc and not term and n == 100
    assert info["outcome"] == "fail" and not info["crossed"] and not info["in_pit"]
    env.close()


def test_a_fall_is_fail(env):
    u = env.unwrapped
    env.reset(seed=0)
    u.data.qpos[3:7] = (math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0)  # on its side
    n, term, trunc, info = _steps(env, 5)
    assert term and info["fell"] and info["outcome"] == "fail" and not info["crossed"]


def test_the_blind_trot_steps_into_a_gap_on_most_courses(env):
    pit = sum(_run(env, seed)[3]["in_pit"] for seed in range(10))
    assert pit >= 8


# -- the support observation ---------------------------------------------------------------


def _square(z=0.0, tilt=0.0):
    """Two facets covering [0, 1]^2 at height z (tilted about y by ``tilt`` rad)."""
    nodes = np.array([[0, 0, z], [1, 0, z + math.tan(tilt)], [1, 1, z + math.tan(tilt)],
                      [0, 1, z]], float)  # fmt: skip
    facets = np.array([[0, 1, 2], [0, 2, 3]])
    n = np.array([-math.sin(tilt), 0.0, math.cos(tilt)])
    return nodes, facets, np.stack([n, n])


def test_perceived_support_on_hand_made_maps():
    p = SupportParams()
    nodes, facets, normals = _square()
    pts = np.array([[0.5, 0.5], [0.2, 0.9], [1.5, 0.5], [-0.01, 0.5]])
    assert perceived_support(pts, nodes, facets, normals, 0.0, p).tolist() == [1, 1, 0, 0]
    # the same facets 5 cm below the level the robot stands at: not its ground
    assert not perceived_support(pts, nodes - [0, 0, 0.05], facets, normals, 0.0, p).any()
    # tilted 30 degrees: too steep (its nodes are off the level too)
    tn, tf, tnorm = _square(tilt=math.radians(30))
    assert not perceived_support(pts, tn, tf, tnorm, 0.0, p).any()
    # a pit node 2 cm beside the point (under 3 cm): unsupported; 4 cm away: supported
    pit = np.vstack([nodes, [[0.52, 0.5, -0.25], [0.2, 0.94, -0.25]]])
    got = perceived_support(pts[:2], pit, facets, normals, 0.0, p)
    assert got.tolist() == [False, True]
    # no map
    assert not perceived_support(pts, nodes, np.zeros((0, 3), int), np.zeros((0, 3)), 0.0, p).any()


def test_foothold_supported_is_read_from_the_map_not_the_stones(env):
    """With the map emptied the key is all 0 although the stones are where they were."""
    u = env.unwrapped
    obs, _ = env.reset(seed=2)
    for _ in range(40):
        obs, *_ = env.step(ZERO)
    aff = u.pipeline.last
    empty = replace(aff, facets=np.zeros((0, 3), np.int64), facet_normals=np.zeros((0, 3)))
    u.pipeline.last = empty
    assert not u.foothold_supported().any()
    obs = u._get_obs()
    assert not obs["foothold_supported"].any() and not obs["foothold_safe"].any()


def test_overlay_footholds_are_green_where_the_observation_says_safe(env):
    """A drawn foothold is green where the observation says the foothold is safe (the map's
    support included: Video S2's green and red circles) and the swing path meets no block; the
    obstacle envs' markers follow the same two keys without the support."""
    from neurocog_gym.envs.obstacle import overlay_markers

    u = env.unwrapped
    env.reset(seed=1)
    green = np.array([0.1, 0.9, 0.2, 0.9])
    seen_green = seen_red = 0
    for _ in range(120):
        obs, *_ = env.step(ZERO)
        drawn = [m for m in overlay_markers(u) if m["size"][0] == 0.025]
        assert len(drawn) == 4
        is_green = np.array([np.allclose(m["rgba"], green) for m in drawn])
        said = obs["foothold_safe"].astype(bool) & ~obs["path_meets_block"].astype(bool)
        np.testing.assert_array_equal(is_green, said)
        assert not (is_green & ~obs["foothold_supported"].astype(bool)).any()
        seen_green += int(is_green.sum())
        seen_red += int((~is_green).sum())
    assert seen_green > 0 and seen_red > 0  # both colours occur on a course
    obstacle = gym.make("NeuroCog/StaticObstacle-v3")
    obstacle.reset(seed=0)
    for _ in range(60):
        obs, *_ = obstacle.step(ZERO)
    said = obs["foothold_safe"].astype(bool) & ~obs["path_meets_block"].astype(bool)
    np.testing.assert_array_equal(obstacle.unwrapped.foothold_marker_safe(), said)
    obstacle.close()


def test_foothold_supported_is_mostly_right_when_it_says_supported(env):
    """Precision against the truth on blind walks: when the map says a swinging leg's foothold
    is on a stone, the stones agree (measured: 100 of 104 on seeds 0-7)."""
    u = env.unwrapped
    said, right = 0, 0
    for seed in range(4):
        env.reset(seed=seed)
        for _ in range(400):
            obs, r, term, trunc, info = env.step(ZERO)
            sw = u.eff.swinging
            sup = obs["foothold_supported"].astype(bool) & sw
            truth = u.stones.support_at(u.data, u.eff.foothold[:, :2])
            said += int(sup.sum())
            right += int((sup & truth).sum())
            if term or trunc:
                break
    assert said >= 10 and right >= 0.9 * said


def test_true_stones_is_the_placed_course():
    env = gym.make(STONES, privileged=True, moving=True)
    obs, _ = env.reset(seed=4)
    u = env.unwrapped
    rows = obs["true_stones"].reshape(24, len(STONE_FIELDS))
    n = 2 + len(u.course.stones)
    assert np.all(rows[:n, 0] == 1) and np.all(rows[n:] == 0)
    torso = u.data.xpos[u.robot.torso_body]
    # the torso at yaw ~0: heading-frame offsets ~ world offsets
    s0 = u.course.stones[0]
    assert np.allclose(rows[2, 1:3], (s0.x - torso[0], s0.y_at(0.0) - torso[1]), atol=0.01)
    assert np.allclose(rows[2, 3:5], (s0.length / 2, s0.width / 2), atol=1e-6)
    assert np.allclose(rows[:n, 5], 0.0, atol=1e-6)
    assert abs(rows[2, 6]) == pytest.approx(s0.speed, rel=1e-5)
    assert rows[0, 6] == 0 and rows[1, 6] == 0
    env.close()


# -- benchmark scenarios -------------------------------------------------------------------


def test_bench_runs_both_stone_scenarios_with_blind(tmp_path):
    from neurocog_gym.bench.runner import BenchConfig, run_benchmark

    cfg = BenchConfig(out=tmp_path / "run", scenarios=("stones", "stones-moving"), trials=2,
                      policy="blind", workers=1, progress=False)  # fmt: skip
    res = run_benchmark(cfg)
    for s in ("stones", "stones-moving"):
        c = res.summary[s]
        assert c["trials"] == 2 and c["touch"] == 0 and c["paper"] is None
    from neurocog_gym.bench.records import load_trials

    recs = load_trials(cfg.out)
    assert len(recs) == 4
    for r in recs:
        assert r["outcome"] in ("success", "fail")
        assert (
            "course" in r
            and "in_pit" in r
            and r["outcome"] == ("success" if r["crossed"] else "fail")
        )
    moving = [r for r in recs if r["scenario"] == "stones-moving"]
    assert all(s["speed"] > 0 for r in moving for s in r["course"]["stones"])
    still = [r for r in recs if r["scenario"] == "stones"]
    assert all(s["speed"] == 0 for r in still for s in r["course"]["stones"])


def test_cli_bench_scenario_stones(tmp_path, capsys):
    from neurocog_gym.cli import main

    out = tmp_path / "cli"
    args = ["bench", "--scenario", "stones-moving", "--trials", "1", "--policy", "blind",
            "--workers", "1", "--out", str(out)]  # fmt: skip
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "stones-moving: " in text and " crossed / " in text and "95 % Wilson" in text
    assert (out / "summary.json").exists() and not (out / "report.md").exists()
