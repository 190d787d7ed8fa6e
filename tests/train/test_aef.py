import subprocess
import sys

import numpy as np
import pytest

from neurocog_gym.locomotion.aef import N_INPUTS, AEFWeights, build_torch_net
from neurocog_gym.train.aef import AEFTrainConfig, build_dataset, train_aef
from neurocog_gym.train.babbling import record_babbling


def test_babbling_records_what_section_6_4_lists():
    b = record_babbling(300, seed=0, progress=False)
    assert b["v"].shape == (300, 4, 3) and b["command"].shape == (300, 12)
    assert np.abs(b["command"]).max() <= 1.0
    assert np.isfinite(b["v"]).all() and np.abs(b["v"]).max() > 0.05  # the legs do move
    # The torso is on a stand: every foot hangs free.
    assert np.all(b["touch_prev"] == 0)


def test_training_lowers_the_loss_on_a_small_set(tmp_path):
    m = train_aef(AEFTrainConfig(samples=1500, epochs=6, patience=10), tmp_path, progress=False)
    hist = [h["val_loss"] for h in m["history"]]
    assert hist[-1] < hist[0]
    assert m["val_loss"] < m["baseline_val_loss"]
    for f in ("metrics.json", "aef_weights.npz", "checkpoint.pt", "babbling.npz", "babbling.png"):
        assert (tmp_path / f).exists()


def test_weights_save_and_load_bit_exactly(tmp_path):
    net = build_torch_net((16, 8))
    w = net.export()
    w.save(tmp_path / "w.npz")
    w2 = AEFWeights.load(tmp_path / "w.npz")
    x = np.random.default_rng(0).normal(size=(5, N_INPUTS))
    a, b = w.forward(x), w2.forward(x)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    # NumPy forward equals the torch forward.
    import torch

    with torch.no_grad():
        ti, tp = net(torch.as_tensor(x, dtype=torch.float32))
    assert np.allclose(a[0], ti.numpy(), atol=1e-5) and np.allclose(a[1], tp.numpy(), atol=1e-5)


def test_corrupt_weights_raise_clearly(tmp_path):
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="corrupt"):
        AEFWeights.load(bad)
    with pytest.raises(FileNotFoundError):
        AEFWeights.load(tmp_path / "missing.npz")


def test_dataset_layout():
    rng = np.random.default_rng(0)
    b = record_babbling(200, seed=1, progress=False)
    X, yi, yp, isp = build_dataset(b, rng, 0.3)
    assert X.shape[1] == 31 and isp.sum() > 0
    assert np.all(yi[isp] == 0) and np.all(yp[~isp] == 0)


def test_cli_train_aef_bad_arguments(tmp_path):
    r = subprocess.run([sys.executable, "-m", "neurocog_gym.cli", "train-aef", "--samples", "-5"],
                       capture_output=True, text=True)  # fmt: skip
    assert r.returncode != 0 and "Traceback" not in r.stderr
    cmd = [sys.executable, "-m", "neurocog_gym.cli", "train-aef", "--samples", "10", "--out",
           str(tmp_path / "bad")]  # fmt: skip
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 2 and "at least 100" in r.stderr and "Traceback" not in r.stderr
