"""Issue 9, item 6: bad arguments and bad files for every subcommand give one line on stderr
that says what is wrong (and what to do), a non-zero exit and no traceback."""

import json
import pickle
import subprocess
import sys

import numpy as np
import pytest

from neurocog_gym import cli
from neurocog_gym.locomotion.gait import default_gait

GARBAGE = b"\x00\x01 this is not what you think \xff"


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Bad files of every kind the commands read, and run folders damaged in known ways."""
    d = tmp_path_factory.mktemp("bad")
    (d / "bad.json").write_text("{not json")
    (d / "wrong_format.json").write_text(json.dumps({"format": "something/1"}))
    (d / "list.json").write_text("[1, 2, 3]")
    g = default_gait().to_json()
    (d / "short_genes.json").write_text(json.dumps({**g, "genes": list(g["genes"])[:10]}))
    (d / "nan_gene.json").write_text(json.dumps({**g, "genes": [float("nan")] * 77}))
    (d / "text_gene.json").write_text(json.dumps({**g, "genes": ["x"] * 77}))
    (d / "garbage.npz").write_bytes(GARBAGE)
    (d / "truncated.npz").write_bytes(b"PK\x03\x04 truncated")
    np.savez(d / "wrong_keys.npz", a=np.zeros(3))
    (d / "garbage.zip").write_bytes(GARBAGE)
    # train-aef folders: damaged babbling data, damaged checkpoints (torch zip and pickle)
    for name, files_ in {
        "aef_babble": {"babbling.npz": b"PK\x03\x04 truncated"},
        "aef_babble2": {"babbling.npz": GARBAGE},
        "aef_ckpt_zip": {"checkpoint.pt": b"PK\x03\x04 truncated"},
        "aef_ckpt_pickle": {"checkpoint.pt": b"\x80\x05 truncated"},
    }.items():
        (d / name).mkdir()
        for fname, data in files_.items():
            (d / name / fname).write_bytes(data)
    from neurocog_gym.train.babbling import record_babbling

    babble = record_babbling(200, seed=0, progress=False)
    for name in ("aef_ckpt_zip", "aef_ckpt_pickle"):
        np.savez_compressed(d / name / "babbling.npz", **babble)
    # tune-cpg folders: a tiny finished run, then damaged copies of it
    from neurocog_gym.train.evaluate import EvalParams
    from neurocog_gym.train.nsga import NSGAConfig, tune_cpg

    cfg = NSGAConfig(pop_size=4, generations=1, eval=EvalParams(seconds=0.2))
    for name in ("nsga_run", "nsga_ckpt", "nsga_pickle", "nsga_runjson", "nsga_hist"):
        tune_cpg(d / name, cfg, workers=1, plots=False, progress=False)
    (d / "nsga_ckpt" / "checkpoint.pkl").write_bytes(GARBAGE)
    (d / "nsga_pickle" / "checkpoint.pkl").write_bytes(pickle.dumps(["not", "a", "checkpoint"]))
    (d / "nsga_runjson" / "run.json").write_text("{broken")
    hist = d / "nsga_hist" / "history.jsonl"
    hist.write_text("garbage\n" + hist.read_text())
    (d / "empty").mkdir()
    # bench folders
    (d / "bench_bad").mkdir()
    (d / "bench_bad" / "trials.jsonl").write_text('{"a": 1}\nnot json\n{"b": 2}\n')
    return d


# (argv, words the one line must contain); {d} is the fixture folder.
CASES = [
    # demo
    (["demo", "--seconds", "-1"], ["--seconds", "positive"]),
    (["demo", "--seconds", "abc"], ["--seconds", "not a number"]),
    (["demo", "--seconds", "inf"], ["--seconds", "finite"]),
    (["demo", "--seconds", "nan"], ["--seconds"]),
    (["demo", "--seed", "-1"], ["--seed", ">= 0"]),
    (["demo", "--seed", "1.5"], ["--seed", "not an integer"]),
    (["demo", "--bogus"], ["unrecognized arguments", "--help"]),
    # tune-cpg: counts
    (["tune-cpg", "--pop-size", "-5", "--out", "{d}/x"], ["pop-size", "at least 4"]),
    (["tune-cpg", "--pop-size", "3", "--out", "{d}/x"], ["pop-size", "at least 4"]),
    (["tune-cpg", "--pop-size", "abc"], ["--pop-size", "invalid int"]),
    (["tune-cpg", "--generations", "0", "--out", "{d}/x"], ["generations", "at least 1"]),
    (["tune-cpg", "--generations", "-2", "--out", "{d}/x"], ["generations", "at least 1"]),
    (["tune-cpg", "--generations", "x"], ["--generations"]),
    (["tune-cpg", "--eval-seconds", "0"], ["--eval-seconds", "positive"]),
    (["tune-cpg", "--eval-seconds", "inf"], ["--eval-seconds", "finite"]),
    (["tune-cpg", "--workers", "0", "--out", "{d}/x"], ["workers", "at least 1"]),
    (["tune-cpg", "--workers", "-2", "--out", "{d}/x"], ["workers", "at least 1"]),
    (["tune-cpg", "--workers", "two"], ["--workers"]),
    (["tune-cpg", "--seed", "-1"], ["--seed", ">= 0"]),
    (["tune-cpg", "--max-drift", "-0.5"], ["--max-drift", ">= 0"]),
    (["tune-cpg", "--max-drift", "inf"], ["--max-drift", "finite"]),
    (["tune-cpg", "--ray-address", "no-port-here", "--out", "{d}/x"], ["not of the form"]),
    # tune-cpg: gait files
    (["tune-cpg", "--base-gait", "{d}/missing.json", "--out", "{d}/x"], ["does not exist"]),
    (["tune-cpg", "--base-gait", "{d}/bad.json", "--out", "{d}/x"], ["not valid JSON"]),
    (["tune-cpg", "--base-gait", "{d}/wrong_format.json", "--out", "{d}/x"], ["neurocog-gait/1"]),
    (["tune-cpg", "--base-gait", "{d}/list.json", "--out", "{d}/x"], ["neurocog-gait/1"]),
    (["tune-cpg", "--base-gait", "{d}/short_genes.json", "--out", "{d}/x"], ["77 genes"]),
    (["tune-cpg", "--base-gait", "{d}/nan_gene.json", "--out", "{d}/x"], ["not finite"]),
    (["tune-cpg", "--base-gait", "{d}/text_gene.json", "--out", "{d}/x"], ["malformed"]),
    (["tune-cpg", "--base-gait", "{d}", "--out", "{d}/x"], ["Is a directory"]),
    # tune-cpg: run folders and checkpoints
    (["tune-cpg", "--out", "{d}/empty", "--resume"], ["no run to resume"]),
    (
        ["tune-cpg", "--out", "{d}/nsga_ckpt", "--resume", "--workers", "1"],
        ["checkpoint", "corrupt"],
    ),
    (["tune-cpg", "--out", "{d}/nsga_pickle", "--resume", "--workers", "1"], ["checkpoint"]),
    (["tune-cpg", "--out", "{d}/nsga_runjson", "--resume"], ["run.json", "corrupt"]),
    (
        ["tune-cpg", "--out", "{d}/nsga_hist", "--resume", "--workers", "1", "--generations", "2"],
        ["history.jsonl", "not valid JSON", "restore it"],
    ),
    (["tune-cpg", "--out", "{d}/nsga_run", "--pop-size", "4"], ["already holds a run", "--resume"]),
    (["tune-cpg", "--out", "{d}/nsga_run", "--resume", "--seed", "9"], ["--seed 9 differs"]),
    (["tune-cpg", "--out", "{d}/nsga_run", "--resume", "--generations", "0"], ["cannot cut"]),
    # train-aef
    (["train-aef", "--samples", "-5"], ["--samples", ">= 0"]),
    (["train-aef", "--samples", "abc"], ["--samples", "not an integer"]),
    (["train-aef", "--samples", "10", "--out", "{d}/x"], ["at least 100"]),
    (["train-aef", "--epochs", "0", "--samples", "200", "--out", "{d}/x"], ["at least 1"]),
    (["train-aef", "--epochs", "x"], ["--epochs"]),
    (
        ["train-aef", "--samples", "200", "--epochs", "1", "--out", "{d}/aef_babble"],
        ["babbling.npz", "corrupt", "delete it"],
    ),
    (
        ["train-aef", "--samples", "200", "--epochs", "1", "--out", "{d}/aef_babble2"],
        ["babbling.npz", "corrupt"],
    ),
    (
        ["train-aef", "--samples", "200", "--epochs", "1", "--out", "{d}/aef_ckpt_zip"],
        ["checkpoint.pt", "corrupt", "delete it"],
    ),
    (
        ["train-aef", "--samples", "200", "--epochs", "1", "--out", "{d}/aef_ckpt_pickle"],
        ["checkpoint.pt", "corrupt"],
    ),
    # bench
    (["bench", "--trials", "-3"], ["--trials", ">= 1"]),
    (["bench", "--trials", "0"], ["--trials", ">= 1"]),
    (["bench", "--trials", "many"], ["--trials", "not an integer"]),
    (["bench", "--scenario", "uphill"], ["--scenario", "invalid choice"]),
    (["bench", "--attention", "maybe"], ["--attention", "invalid choice"]),
    (["bench", "--max-seconds", "-1"], ["--max-seconds", "positive"]),
    (["bench", "--max-seconds", "inf"], ["--max-seconds", "finite"]),
    (["bench", "--workers", "0"], ["--workers", ">= 1"]),
    (["bench", "--seed", "-4"], ["--seed", ">= 0"]),
    (["bench", "--policy", "nonsense", "--out", "{d}/x"], ["does not exist"]),
    (["bench", "--policy", "{d}/missing.zip", "--out", "{d}/x"], ["does not exist"]),
    (["bench", "--policy", "{d}/garbage.zip", "--out", "{d}/x"], ["stable-baselines3"]),
    (["bench", "--policy", "{d}/missing.npz", "--out", "{d}/x"], ["does not exist"]),
    (["bench", "--policy", "{d}/garbage.npz", "--out", "{d}/x"], ["AEF weights", "corrupt"]),
    (["bench", "--policy", "{d}/truncated.npz", "--out", "{d}/x"], ["AEF weights", "corrupt"]),
    (["bench", "--policy", "{d}/wrong_keys.npz", "--out", "{d}/x"], ["AEF weights", "lacks"]),
    (
        ["bench", "--out", "{d}/bench_bad", "--resume", "--trials", "1", "--workers", "1"],
        ["trials.jsonl", "line 2", "not valid JSON"],
    ),
    # bench-report
    (["bench-report", "{d}/nonexistent"], ["does not exist"]),
    (["bench-report", "{d}/empty"], ["no trials.jsonl"]),
    (["bench-report", "{d}/bench_bad"], ["line 2", "not valid JSON"]),
    (["bench-report"], ["required"]),
    # the command itself
    ([], ["required"]),
    (["fly"], ["invalid choice"]),
]


def _id(case):
    return " ".join(case[0])[:60] or "(none)"


@pytest.mark.parametrize(("argv", "words"), CASES, ids=[_id(c) for c in CASES])
def test_bad_input_is_one_line(files, capsys, monkeypatch, argv, words):
    monkeypatch.chdir(files)  # default output folders land in the fixture, never in the repo
    argv = [a.replace("{d}", str(files)) for a in argv]
    try:
        rc = cli.main(argv)
    except SystemExit as e:
        rc = e.code
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert rc not in (0, None), err
    assert len(lines) == 1, err
    assert "error" in lines[0] and "Traceback" not in err
    for w in words:
        assert w in lines[0], lines[0]


@pytest.mark.parametrize(
    "argv",
    [
        ["demo", "--seconds", "inf"],
        ["tune-cpg", "--pop-size", "x"],
        ["bench", "--policy", "{d}/garbage.npz", "--out", "{d}/x"],
        ["train-aef", "--samples", "200", "--epochs", "1", "--out", "{d}/aef_ckpt_zip"],
    ],
)
def test_bad_input_in_a_real_process(files, argv):
    argv = [a.replace("{d}", str(files)) for a in argv]
    res = subprocess.run([sys.executable, "-m", "neurocog_gym.cli", *argv], cwd=files,
                         capture_output=True, text=True, timeout=180)  # fmt: skip
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert res.returncode == 2 and len(lines) == 1 and "Traceback" not in res.stderr, res.stderr


def test_an_unexpected_exception_is_one_line_unless_debugging(capsys, monkeypatch):
    def boom(args):
        raise ZeroDivisionError("deep inside")

    parser = cli.build_parser()
    monkeypatch.setattr(cli, "build_parser", lambda: parser)
    parser._subparsers._group_actions[0].choices["demo"].set_defaults(func=boom)
    assert cli.main(["demo"]) == 3
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "ZeroDivisionError: deep inside" in err
    monkeypatch.setenv("NEUROCOG_DEBUG", "1")
    with pytest.raises(ZeroDivisionError):
        cli.main(["demo"])


def test_unknown_env_id_names_the_known_ones():
    from neurocog_gym.envs.base import make_env

    with pytest.raises(ValueError, match="unknown env id 'NeuroCog/Fly-v0'; known: .*Walk-v3"):
        make_env("NeuroCog/Fly-v0")
