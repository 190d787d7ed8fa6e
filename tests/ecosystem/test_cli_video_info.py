"""neurocog record-video and neurocog info; --help of every subcommand."""

import argparse
import json

import gymnasium as gym
import imageio.v2 as imageio
import numpy as np
import pytest

import neurocog_gym
from neurocog_gym import cli
from neurocog_gym.video import record_video


def _frames(path):
    with imageio.get_reader(path) as r:
        return [np.asarray(f) for f in r]


def test_every_subcommand_has_complete_help():
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    names = set(sub.choices)
    assert {"demo", "bench", "tune-cpg", "train-aef", "record-video", "info"} <= names
    helps = {c.dest: c.help for c in sub._choices_actions}
    for name, p in sub.choices.items():
        assert helps.get(name), f"{name} has no one-line help in `neurocog --help`"
        for action in p._actions:
            if isinstance(action, argparse._HelpAction):
                continue
            assert action.help, f"neurocog {name} {action.option_strings or action.dest}: no help"
        text = p.format_help()
        for action in p._actions:
            for opt in action.option_strings:
                assert opt in text


def test_info_json_matches_the_registry(capsys):
    assert cli.main(["info", "--json"]) == 0
    descs = json.loads(capsys.readouterr().out)
    assert [d["id"] for d in descs] == list(neurocog_gym.ENV_IDS)
    for d in descs:
        env = gym.make(d["id"])
        assert d["max_episode_steps"] == gym.spec(d["id"]).max_episode_steps
        assert d["vector_entry_point"] == gym.spec(d["id"]).vector_entry_point
        assert d["episode_seconds"] == pytest.approx(d["max_episode_steps"] * env.unwrapped.dt)
        assert set(d["observation"]) == set(env.observation_space.spaces)
        assert d["action_space"].startswith("Box(-1, 1, (15,)")
        names = [p["name"] for p in d["parameters"]]
        assert {"target_speed", "frame_skip", "camera_name", "width", "height"} <= set(names)
        if "Obstacle" in d["id"]:
            assert {"tof", "perception", "include_graph", "warmup_cycles"} <= set(names)
        env.close()
    static = next(d for d in descs if d["id"] == "NeuroCog/StaticObstacle-v3")
    assert {"n_blocks", "first_distance", "lateral"} <= {p["name"] for p in static["parameters"]}


def test_info_text_one_env(capsys):
    assert cli.main(["info", "--env", "NeuroCog/Walk-v3"]) == 0
    out = capsys.readouterr().out
    assert "NeuroCog/Walk-v3" in out and "2000 steps" in out and "joint_pos" in out
    assert "make_vec(id, n): neurocog_gym.envs.make_vec:walk_vector" in out
    assert "SuddenObstacle" not in out


def test_record_video_walk_writes_the_frames(tmp_path, capsys):
    out = tmp_path / "walk.mp4"
    rc = cli.main(
        [
            "record-video",
            "--env",
            "NeuroCog/Walk-v3",
            "--policy",
            "blind",
            "--seconds",
            "0.2",
            "--width",
            "96",
            "--height",
            "64",
            "--fps",
            "50",
            "--out",
            str(out),
            "--quiet",
        ]
    )
    assert rc == 0
    assert str(out) in capsys.readouterr().out
    frames = _frames(out)
    # the reset frame plus one every 2 control cycles of 0.01 s: 1 + 20 / 2
    assert len(frames) == 11
    assert frames[0].shape == (64, 96, 3)
    assert frames[0].std() > 0  # a scene, not a blank buffer


def test_record_video_draws_the_overlay(tmp_path):
    common = dict(
        env_id="NeuroCog/SuddenObstacle-v3",
        policy="aef",
        seconds=0.05,
        seed=2,
        camera="overhead",
        width=128,
        height=96,
        fps=100,
    )
    with_overlay = record_video(out=tmp_path / "a.mp4", **common)
    plain = record_video(out=tmp_path / "b.mp4", env_kwargs={"draw_overlay": False}, **common)
    assert with_overlay["frames"] == plain["frames"] == 6
    assert with_overlay["distance_m"] == plain["distance_m"]  # the same episode
    a, b = _frames(tmp_path / "a.mp4"), _frames(tmp_path / "b.mp4")
    diff = np.abs(a[-1].astype(int) - b[-1].astype(int)).max(axis=2)
    assert (diff > 40).sum() > 50  # the graph, facets and footholds are drawn in


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--camera", "nope"], ["unknown camera", "follow"]),
        (["--width", "15"], ["--width", "even"]),
        (["--height", "abc"], ["--height"]),
        (["--fps", "500"], ["--fps", "100"]),
        (["--seconds", "-1"], ["--seconds", "positive"]),
        (["--env", "Nope-v0"], ["unknown env id", "NeuroCog/Walk-v3"]),
        (["--env", "NeuroCog/Walk-v3"], ["remembered_blocks", "blind"]),
        (["--out", "{tmp}/v.avi"], [".mp4"]),
        (["--policy", "{tmp}/missing.zip"], ["missing.zip"]),
    ],
)
def test_record_video_bad_input_is_one_line(tmp_path, capsys, argv, words):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    if "--out" not in argv:
        argv += ["--out", str(tmp_path / "v.mp4")]
    try:
        rc = cli.main(["record-video", "--quiet", "--seconds", "0.05", *argv])
    except SystemExit as e:  # argparse errors
        rc = e.code
    err = capsys.readouterr().err
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    for w in words:
        assert w in lines[0]
    assert not (tmp_path / "v.mp4").exists()


def test_info_unknown_env(capsys):
    assert cli.main(["info", "--env", "Nope-v0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown env id" in err[0]
