"""`neurocog demo`: the walk and the short obstacle benchmark behind `make demo`."""

from neurocog_gym import cli


def test_demo_walks_then_runs_a_short_benchmark(tmp_path, capsys):
    out = tmp_path / "demo"
    code = cli.main(["demo", "--out", str(out), "--seconds", "0.5", "--no-video",
                     "--trials", "1", "--policies", "blind", "--workers", "1"])  # fmt: skip
    assert code == 0
    text = capsys.readouterr().out
    assert "walked" in text
    # The Table 4 rows: the paper's and ours, for both scenarios.
    assert "| sudden | **paper (real robot)** | 50 | 28 | 13 | 9 |" in text
    assert "| static | blind, attention on | 1 |" in text
    assert (out / "bench" / "report.md").is_file()
    assert (out / "bench" / "blind" / "trials.jsonl").read_text().count("\n") == 2


def test_the_walk_is_not_reported_as_a_fall_when_its_time_is_up(tmp_path):
    """20 s is Walk-v3's registered time limit: the truncation at the end is not a fall."""
    from neurocog_gym.demo import walk_demo

    summary = walk_demo(tmp_path, seconds=20.0, video=False)
    assert summary["fell_at_s"] is None
    assert abs(summary["seconds"] - 20.0) < 1e-9
    assert 0.4 < summary["speed_m_per_s"] < 0.6
