"""The §6.2 latency chain per sudden trial and Table 5 by outcome (issue 23, items 3 and 4)."""

from __future__ import annotations

import json
import math
from types import SimpleNamespace

import gymnasium as gym
import numpy as np
import pytest

import neurocog_gym  # noqa: F401  (registers the ids)
from neurocog_gym import io
from neurocog_gym.bench import outcome, runner
from neurocog_gym.bench.report import write_report
from neurocog_gym.perception.affordance import AffordanceObject
from neurocog_gym.robot.obstacles import Block

# -- LatencyProbe on hand-made perception -------------------------------------------------------


def _obj(height, length, box, n_nodes=10, width=0.2):
    up = np.array([0.0, 0.0, 1.0])
    return AffordanceObject("object", np.zeros(3), height, width, length, 0.0, 0.0, up, 0.01,
                            n_nodes, np.asarray(box), False)  # fmt: skip


def _pipe(nodes, objects, ground_z=0.0, facets=()):
    """A pipeline after a step: ``nodes``, the ``objects`` and the ``facets`` (index triples
    into ``nodes``) with their unit normals, pointing up."""
    nodes = np.asarray(nodes, float).reshape(-1, 3)
    f = np.asarray(facets, np.int64).reshape(-1, 3)
    n = np.cross(nodes[f[:, 1]] - nodes[f[:, 0]], nodes[f[:, 2]] - nodes[f[:, 0]])
    n = n / np.linalg.norm(n, axis=1, keepdims=True) if len(f) else np.zeros((0, 3))
    n *= np.where(n[:, 2:] < 0, -1.0, 1.0)
    aff = SimpleNamespace(objects=objects, obstacles=objects, ground_z=ground_z, facets=f,
                          facet_normals=n)  # fmt: skip
    return SimpleNamespace(net=SimpleNamespace(nodes=nodes), last=aff)


ON_BLOCK = [[0.95, 0.0, 0.9], [1.05, 0.1, 0.9]]
"""Box (min, max) overlapping the test block's footprint, z ignored."""
ELSEWHERE = [[2.0, 2.0, 0.0], [2.1, 2.1, 0.1]]


# A fan round the node at (cx, 0, z): four floor nodes r = 20 cm away along ±x and ±y, four
# facets. Each facet, through (0, 0, z), (r, 0, 0), (0, r, 0) up to symmetry, has the normal
# (z, z, r) / |.|, tilted from the vertical by atan(sqrt(2) z / r).
FAN_FACETS = [(0, 1, 2), (0, 2, 3), (0, 3, 4), (0, 4, 1)]


def _fan(z, cx=1.0, r=0.2):
    return [[cx, 0.0, z], [cx + r, 0.0, 0.0], [cx, r, 0.0], [cx - r, 0.0, 0.0], [cx, -r, 0.0]]


def test_latency_probe_by_hand():
    # Block 10 cm long (x), 20 cm wide, 7 cm high at (1, 0); heading +x, so true length 0.10.
    block = Block(1.0, 0.0, 0.10, 0.20, 0.07)
    p = runner.LatencyProbe(2.0, block, max_tilt=math.radians(20), n_blocks=1)
    assert p.margin == 0.05
    floor = [[1.0, 0.0, 0.005]]
    fwd = np.array([1.0, 0.0])
    # t = 1.99, before the appearance: nothing counts, not even a steep fan on the block.
    p.perceived(1.99, _pipe(_fan(0.07), [_obj(0.07, 0.10, ON_BLOCK)], facets=FAN_FACETS), fwd,
                sees_block=True)  # fmt: skip
    p.control(1.99, True)
    # t = 2.00: one node 3 cm up in the footprint (x 0.95-1.05, y ±0.1), its facets tilted by
    # atan(1.414 * 0.03 / 0.2) = 12.0° < 20°: homogeneous (the old definition, a node more
    # than 2 cm over the ground in the footprint, counted it); a steep fan, 10 cm high
    # (atan(1.414 * 0.1 / 0.2) = 35.3°), centred at x = 1.35: its nearest node, x = 1.15, is
    # beyond the margin (1.05 + 0.05); an accurate object elsewhere, with more nodes, is not
    # on the block.
    nodes = _fan(0.03) + _fan(0.1, cx=1.35)
    facets = FAN_FACETS + [(a + 5, b + 5, c + 5) for a, b, c in FAN_FACETS]
    p.perceived(2.00, _pipe(nodes, [_obj(0.07, 0.10, ELSEWHERE, n_nodes=50)], facets=facets),
                fwd)  # fmt: skip
    p.control(2.00, False)
    assert p.first_nonhomogeneous is None and p.first_object is None and p.first_interrupt is None
    assert p.first_frame is None
    # t = 2.01: the node is 8 cm up, its facets tilted atan(1.414 * 0.08 / 0.2) = 29.5° > 20°
    # (the z <= 0.07 + 0.05 of the region): non-homogeneous nodes on the block; the frame sees
    # the block; the object on the block is 2 cm low: |dh| / 1 cm = 2, |dl| / 2 cm = 0 -> a
    # miss of 2.
    p.perceived(2.01, _pipe(_fan(0.08), [_obj(0.05, 0.10, ON_BLOCK)], facets=FAN_FACETS), fwd,
                sees_block=True)  # fmt: skip
    assert p.first_nonhomogeneous == pytest.approx(0.01) and p.first_frame == pytest.approx(0.01)
    assert p.first_object == pytest.approx(0.01) and p.accurate is None
    assert p.compared["height"] == 0.05 and not p.compared["accurate"]
    # t = 2.02: dh = -0.5 cm (ok), dl = +3 cm (> 2 cm): a miss of 1.5, nearer than 2.
    p.perceived(2.02, _pipe(floor, [_obj(0.065, 0.13, ON_BLOCK)]), fwd)
    assert p.accurate is None and p.compared["length"] == 0.13
    # t = 2.025: dh = -4 cm, a miss of 4: farther, so the nearest miss stays.
    p.perceived(2.025, _pipe(floor, [_obj(0.03, 0.10, ON_BLOCK)]), fwd)
    assert p.compared["length"] == 0.13
    # t = 2.03: dh = +0.5 cm, dl = +1.5 cm: accurate 0.03 s after the appearance.
    p.perceived(2.03, _pipe(floor, [_obj(0.075, 0.115, ON_BLOCK)]), fwd)
    p.control(2.04, True)
    p.control(2.05, True)
    res = p.result()
    assert res["first_nonhomogeneous_s"] == 0.01 and res["first_object_s"] == 0.01
    assert res["first_frame_s"] == 0.01
    assert res["accurate_s"] == 0.03
    assert res["first_interrupt_s"] == 0.04  # 2.04 - 2.00; the one at 1.99 was before
    c = res["compared"]
    assert c["accurate"] and c["at_s"] == 0.03
    assert (c["height"], c["length"], c["true_height"], c["true_length"]) == (
        0.075, 0.115, 0.07, 0.1)  # fmt: skip
    # Later, worse readings do not undo it.
    p.perceived(2.1, _pipe(floor, [_obj(0.02, 0.5, ON_BLOCK)]), fwd)
    assert p.result() == res
    json.dumps(res, allow_nan=False)


def test_latency_probe_measures_length_along_the_heading():
    # Heading +y: the block's length along it is its 20 cm width.
    block = Block(1.0, 0.0, 0.10, 0.20, 0.07)
    p = runner.LatencyProbe(0.0, block, max_tilt=math.radians(20))
    p.perceived(0.05, _pipe([[1.0, 0.0, 0.0]], [_obj(0.07, 0.10, ON_BLOCK)]), np.array([0, 1.0]))
    assert p.accurate is None and p.compared["true_length"] == pytest.approx(0.2)
    p.perceived(0.06, _pipe([[1.0, 0.0, 0.0]], [_obj(0.07, 0.21, ON_BLOCK)]), np.array([0, 1.0]))
    assert p.accurate == pytest.approx(0.06)
    # No facet ever: the first non-homogeneous nodes stay None.
    assert p.result()["first_nonhomogeneous_s"] is None


def test_nonhomogeneous_nodes_within_the_margin_only():
    # The steep fan (35.3°) centred at x = 1.36: its nearest node, x = 1.16, is 11 cm off the
    # footprint's x = 1.05 edge: outside a 5 cm margin, inside a 12 cm one.
    block = Block(1.0, 0.0, 0.10, 0.20, 0.07)
    fwd = np.array([1.0, 0.0])
    far = _pipe(_fan(0.1, cx=1.36), [], facets=FAN_FACETS)
    p = runner.LatencyProbe(0.0, block, max_tilt=math.radians(20))
    p.perceived(0.01, far, fwd)
    assert p.first_nonhomogeneous is None
    wide = runner.LatencyProbe(0.0, block, max_tilt=math.radians(20), margin=0.12)
    wide.perceived(0.01, far, fwd)
    assert wide.first_nonhomogeneous == pytest.approx(0.01)
    # The same fan with a 40° threshold: 35.3° is homogeneous.
    steep = runner.LatencyProbe(0.0, block, max_tilt=math.radians(40), margin=0.12)
    steep.perceived(0.01, far, fwd)
    assert steep.first_nonhomogeneous is None


# -- on a real, short sudden trial --------------------------------------------------------------


def _nonhomogeneous_on(block, nodes, facets, max_tilt, margin=0.05):
    """NumPy oracle of "non-homogeneous nodes on the block": a corner, within ``margin`` of the
    footprint (and of the top), of a facet whose normal (from its corners, not the detector's
    normals) is tilted from the vertical by more than ``max_tilt``."""
    if len(facets) == 0:
        return False
    a, b, c3 = (nodes[facets[:, k]] for k in range(3))
    n = np.cross(b - a, c3 - a)
    tilt = np.arccos(np.abs(n[:, 2]) / np.linalg.norm(n, axis=1))
    ids = np.unique(facets[tilt > max_tilt])
    c, s = math.cos(block.yaw), math.sin(block.yaw)
    d = nodes[ids, :2] - (block.x, block.y)
    u, v = d @ (c, s), d @ (-s, c)
    inside = (np.abs(u) <= block.length / 2 + margin) & (np.abs(v) <= block.width / 2 + margin)
    return bool((inside & (nodes[ids, 2] <= block.height + margin)).any())


class _Scripted:
    """Zero action, plus interrupt entry 0 before the block (ignored) and from 0.05 s after."""

    def __init__(self, env):
        self.u = env.unwrapped
        self.raised_at: float | None = None
        self.seen_at: float | None = None

    def __call__(self, obs):
        u, t = self.u, float(self.u.data.time)
        a = np.zeros(15, np.float32)
        if 0.30 - 1e-9 <= t < 0.35 - 1e-9:
            a[0] = 0.2
        t0 = u.appeared_at
        if t0 is not None:
            # The state the policy sees is the perception step that ended at t.
            aff = u.pipeline.last
            tilt = u.pipeline.affordance_params.terrain_max_tilt
            nodes = np.asarray(u.pipeline.net.nodes)
            if self.raised_at is None and _nonhomogeneous_on(
                u.pool.blocks[0], nodes, aff.facets, tilt
            ):
                self.raised_at = round(t - t0, 4)
            if self.seen_at is None and (u.frame.geom == u.pool.geoms[0]).any():
                self.seen_at = round(t - t0, 4)
            if t >= t0 + 0.05 - 1e-9:
                a[0] = 0.2
        return a


def test_latency_fields_on_a_short_scripted_sudden_trial():
    env = gym.make("NeuroCog/SuddenObstacle-v3", max_episode_steps=150, appear_window=(0.4, 0.5))
    pol = _Scripted(env)
    rec = runner.run_trial(env, pol, runner.TrialSpec("sudden", 0, 3))
    env.close()
    lat = rec["latency"]
    assert set(runner.NO_LATENCY) == set(lat)
    assert rec["appeared_at"] is not None and rec["time"] > rec["appeared_at"] + 0.3
    # The interrupts at 0.30-0.34 s came before the block and do not count.
    assert rec["interrupt_cycles"] >= 5 + 1
    assert lat["first_interrupt_s"] == pytest.approx(0.05, abs=1e-9)
    assert lat["first_nonhomogeneous_s"] is not None
    assert lat["first_nonhomogeneous_s"] == pol.raised_at
    assert lat["first_frame_s"] is not None and lat["first_frame_s"] == pol.seen_at
    assert lat["n_blocks"] == len(rec["obstacles"]) >= 1
    c = lat["compared"]
    assert c is not None
    assert c["true_height"] == pytest.approx(rec["obstacles"][0]["height"], abs=1e-5)
    if lat["accurate_s"] is not None:
        assert c["accurate"] and c["at_s"] == lat["accurate_s"]
        assert abs(c["height"] - c["true_height"]) <= runner.ACCURATE_HEIGHT
        assert abs(c["length"] - c["true_length"]) <= runner.ACCURATE_LENGTH
    else:
        assert not c["accurate"]
    assert rec["perception"] == {"gng": "ddgng", "affordance_source": "points"}
    json.dumps(rec, allow_nan=False)


def test_latency_is_none_before_the_block_and_on_static_trials():
    env = gym.make("NeuroCog/SuddenObstacle-v3", max_episode_steps=20)  # 0.2 s: no block yet
    rec = runner.run_trial(env, lambda obs: np.zeros(15, np.float32),
                           runner.TrialSpec("sudden", 0, 1))  # fmt: skip
    env.close()
    assert rec["appeared_at"] is None and rec["latency"] == runner.NO_LATENCY
    env = gym.make("NeuroCog/StaticObstacle-v3", max_episode_steps=5)
    rec = runner.run_trial(env, lambda obs: np.zeros(15, np.float32),
                           runner.TrialSpec("static", 0, 1))  # fmt: skip
    env.close()
    assert rec["latency"] is None


def test_attention_and_affordance_source_reach_the_env():
    env = runner.make_env("sudden", "mlgng", 0.1, False, "map")
    u = env.unwrapped
    assert type(u.pipeline.net).__name__ == "MLGNG"
    assert u.pipeline.params.affordance_source == "map"
    env.close()
    env = runner.make_env("sudden", "off", 0.1)
    assert type(env.unwrapped.pipeline.net).__name__ == "GNG"
    assert env.unwrapped.pipeline.params.affordance_source == "points"
    env.close()
    with pytest.raises(ValueError, match="affordance_source"):
        runner.BenchConfig(out="x", affordance_source="raw")
    with pytest.raises(ValueError, match="attention"):
        runner.BenchConfig(out="x", attention="dd")
    cfg = runner.BenchConfig(out="x", affordance_source="map")
    assert cfg.identity()["affordance_source"] == "map"


def test_cli_passes_the_affordance_source(monkeypatch):
    from neurocog_gym import cli

    seen = {}

    def fake_run(cfg):
        seen["cfg"] = cfg
        raise RuntimeError("stop here")

    monkeypatch.setattr(runner, "run_benchmark", fake_run)
    rc = cli.main(["bench", "--scenario", "sudden", "--affordance-source", "map",
                   "--attention", "mlgng", "--out", "unused"])  # fmt: skip
    assert rc == 2 and seen["cfg"].affordance_source == "map"
    assert seen["cfg"].attention == "mlgng"
    with pytest.raises(SystemExit):
        cli.build_parser().parse_args(["bench", "--affordance-source", "raw"])


# -- Table 5 by outcome and the latency medians, on hand-made records ---------------------------


def _rec(i, out, sim, lat):
    return {"scenario": "sudden", "index": i, "seed": i, "outcome": out,
            "passed": out != "fail", "time": 3.0, "appeared_at": 1.5, "similarity": sim,
            "latency": lat, "policy": "aef", "attention": "on", "run_seed": 0,
            "max_seconds": None, "affordance_source": None}  # fmt: skip


def _sim(best, ttb, at):
    return {"best": best, "time_to_best": ttb, "at_0_5": at}


def _lat(nh, acc, it):
    return {"first_nonhomogeneous_s": nh, "accurate_s": acc, "first_interrupt_s": it}


RECORDS = [
    _rec(0, "success", _sim(0.9, 0.4, 0.9), _lat(0.02, 0.10, 0.15)),
    _rec(1, "success", _sim(0.8, 0.6, 0.7), _lat(0.04, 0.30, None)),
    _rec(2, "touch", _sim(0.7, 0.3, None), _lat(0.01, None, None)),
    _rec(3, "fail", _sim(0.6, 0.9, 0.4), _lat(0.05, 0.20, 0.30)),
    _rec(4, "fail", None, _lat(None, None, None)),
]


def test_similarity_by_outcome_by_hand():
    by = outcome.similarity_by_outcome(RECORDS)
    # success: best (0.9 + 0.8) / 2 = 0.85, time (0.4 + 0.6) / 2 = 0.5, at 0.5 s 0.8.
    assert by["success"]["n"] == 2
    assert by["success"]["best"] == pytest.approx(0.85)
    assert by["success"]["time_to_best"] == pytest.approx(0.5)
    assert by["success"]["at_0_5"] == pytest.approx(0.8)
    # touch: one trial, no value at 0.5 s.
    assert (by["touch"]["n"], by["touch"]["best"], by["touch"]["at_0_5"]) == (1, 0.7, None)
    # fail: two trials, one without a curve: the means are of the other.
    assert by["fail"]["n"] == 2 and by["fail"]["time_to_best"] == pytest.approx(0.9)


def test_latency_summary_by_hand():
    by = outcome.latency_by_outcome(RECORDS)
    a = by["all"]
    # Never = infinitely late. Non-homogeneous sorted: 0.01 0.02 0.04 0.05 inf -> median
    # 0.04; quartiles at positions 0.25 * 4 = 1 and 0.75 * 4 = 3: 0.02 and 0.05.
    nh = a["first_nonhomogeneous_s"]
    assert a["n"] == 5 and nh == {"median": 0.04, "q1": 0.02, "q3": 0.05, "happened": 4}
    # Accurate: 0.10 0.20 0.30 inf inf -> 0.30, q1 0.20, q3 never; within 0.25 s: 0.10, 0.20
    # -> 2 of 5, Wilson interval (k + z²/2) / (n + z²) ± z sqrt(k (n - k) / n + z²/4) / (n + z²)
    # with z = 1.96: centre 3.921 / 8.841 = 0.4435, half 1.96 * sqrt(1.2 + 0.9604) / 8.841
    # = 0.3259 -> [0.118, 0.769].
    assert a["accurate_s"] == {"median": pytest.approx(0.30), "q1": pytest.approx(0.20),
                               "q3": None, "happened": 3}  # fmt: skip
    assert a["accurate_within"] == pytest.approx(0.4)
    assert a["accurate_within_ci"] == pytest.approx([0.1176, 0.7694], abs=1e-3)
    # Interrupt: 0.15 0.30 inf inf inf -> the median is never, the first quartile 0.30.
    assert a["first_interrupt_s"] == {"median": None, "q1": 0.30, "q3": None, "happened": 2}
    # Between a time and a never: never (np.quantile would give NaN).
    assert outcome._quantile(np.array([0.1, math.inf]), 0.5) == math.inf
    assert outcome._quantile(np.array([0.1, 0.3]), 0.5) == pytest.approx(0.2)
    s = by["success"]
    assert s["n"] == 2 and s["first_nonhomogeneous_s"]["median"] == pytest.approx(0.03)
    assert s["accurate_s"]["median"] == pytest.approx(0.2) and s["accurate_within"] == 0.5
    assert s["first_interrupt_s"]["median"] is None  # median of 0.15 and never
    assert by["fail"]["accurate_s"]["median"] is None and by["fail"]["accurate_within"] == 0.5
    # Trials without a latency (static, older runs) are left out.
    none = outcome.latency_summary([{"outcome": "fail", "latency": None}])
    assert none["n"] == 0 and none["accurate_within"] is None


def test_report_has_table5_by_outcome_the_latency_table_and_plot(tmp_path):
    run = tmp_path / "run"
    for r in RECORDS:
        io.append_jsonl(run / "trials.jsonl", r)
    md = write_report([run], tmp_path / "rep").read_text()
    assert "| **paper (real robot)** | – | success | – | 0.92 | 0.45 | 0.92 |" in md
    assert "| **paper (real robot)** | – | failed | – | 0.89 | 0.75 | 0.48 |" in md
    assert "| AEF, attention on | sudden | success | 2 | 0.85 | 0.50 | 0.80 |" in md
    assert "| AEF, attention on | sudden | touch | 1 | 0.70 | 0.30 | – |" in md
    assert "| AEF, attention on | sudden | fail | 2 | 0.60 | 0.90 | 0.40 |" in md
    assert "| 1 | – | 0.10 | 0.21 | – | ≈ 0.21 |" in md  # the paper's §6.2 row
    # The hand-made records have no first frame: never. Quartiles and intervals as in
    # test_latency_summary_by_hand; touch, 0 of 1: Wilson centre 1.921 / 4.841 = 0.397, half
    # 1.96 * sqrt(0.9604) / 4.841 = 0.397 -> [0, 79].
    assert ("| AEF, attention on | all | 5 | never [never–never] (0 of 5) "
            "| 0.04 [0.02–0.05] (4 of 5) | 0.30 [0.20–never] (3 of 5) | 40 % [12, 77] "
            "| never [0.30–never] (2 of 5) |") in md  # fmt: skip
    touch = (
        "| AEF, attention on | touch | 1 | never [never–never] (0 of 1) "
        "| 0.01 [0.01–0.01] (1 of 1) | never [never–never] (0 of 1) | 0 % [0, 79] |"
    )
    assert touch in md
    assert (tmp_path / "rep" / "latency.png").stat().st_size > 1000
