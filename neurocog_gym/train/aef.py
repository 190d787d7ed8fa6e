"""AEF training by backpropagation (§6.4): motor babbling -> inverse model, plus the provision head.

Dataset rows (31 inputs, see ``locomotion.aef.INPUT_NAMES``):

* **Interrupt rows** (from motor babbling): the 4 x 3 interrupt directions are the recorded foot
  velocities v(t); the joint angles are theta(t-1); touch is noise (see ``babbling.py``); A_h, A_w,
  A_s are drawn at random (on the stand there is no object; the head must not depend on them).
  Target: the interrupt head's 12 outputs = the babbled command Theta(t-1).
* **Provision rows** (geometric teacher): the fit's two provision rules — the
  walk-around of an obstacle on or beside the path (``_fit_kernel.walk_around_kernel``: s_SAG
  0, s_COR, s_DIR 0) and the stop / side-step / pass of a block that appears within reach
  (``locomotion/avoidance.py``: s_SAG down to -1, the brake; s_COR ±1; s_DIR holding the
  heading) — fill every leg's direction slot with the body motion (s_SAG, s_COR, s_DIR) they
  chose; the provision head learns to output (s_SAG, s_COR, s_DIR) = (d_x, d_y, d_z) from those
  inputs. Rows draw s_SAG from [-1, 0.2] (a quarter of them exactly -1, the back-off), s_COR
  from [-1, 1] (a fifth 0, a fifth ±1) and s_DIR from [-1, 1] (half of them 0). Joint angles
  and touch come from babbling rows, A at random. The rows sample that range, not the rules'
  outputs, so a change of the rules within it leaves the dataset, and the trained weights, as
  they were (issue 22, 2026-12-05: retrained after the walk-round's change, bit for bit the
  shipped file).

Loss: mean squared error of each head on its own rows. Validation: a held-out 20 % split;
``baseline_val_loss`` is the loss of predicting the training mean. Early stopping on the
validation loss; a checkpoint (``checkpoint.pt``) after every epoch, so a killed run resumes.
"""

from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from neurocog_gym import io as nio
from neurocog_gym.locomotion.aef import N_INPUTS, build_torch_net


@dataclass(frozen=True)
class AEFTrainConfig:
    """Training hyper-parameters (kept apart from the model)."""

    samples: int = 40000
    epochs: int = 60
    seed: int = 0
    batch_size: int = 256
    lr: float = 2e-3
    hidden: tuple[int, ...] = (64, 64)
    val_share: float = 0.2
    provision_share: float = 0.3
    patience: int = 8


def build_dataset(babble: dict[str, np.ndarray], rng: np.random.Generator, provision_share: float):
    """Turn babbling records into (X (n, 31), Y_int (n, 12), Y_prov (n, 3), is_prov (n,))."""
    n_int = len(babble["command"])
    n_prov = int(round(n_int * provision_share / (1 - provision_share)))
    n = n_int + n_prov
    X = np.zeros((n, N_INPUTS))
    A = np.column_stack([rng.uniform(0, 0.12, n), rng.uniform(0, 0.4, n), rng.uniform(0, 0.3, n)])
    X[:, 0:3] = A
    X[:n_int, 3:15] = babble["v"].reshape(n_int, 12)
    X[:n_int, 15:27] = babble["theta_prev"]
    X[:, 27:31] = rng.uniform(0, 2, (n, 4))
    y_int = np.zeros((n, 12))
    y_int[:n_int] = babble["command"]
    # Provision rows: the teacher's desired body motion in every leg's direction slot.
    prov = np.column_stack(
        [rng.uniform(-1, 0.2, n_prov), rng.uniform(-1, 1, n_prov), rng.uniform(-1, 1, n_prov)]
    )
    prov[rng.random(n_prov) < 0.25, 0] = -1.0
    u = rng.random(n_prov)
    prov[u < 0.2, 1] = 0.0
    prov[(u >= 0.2) & (u < 0.4), 1] = np.sign(prov[(u >= 0.2) & (u < 0.4), 1])
    prov[rng.random(n_prov) < 0.5, 2] = 0.0
    X[n_int:, 3:15] = np.tile(prov, 4)
    X[n_int:, 15:27] = babble["theta_prev"][rng.integers(0, n_int, n_prov)]
    y_prov = np.zeros((n, 3))
    y_prov[n_int:] = prov
    is_prov = np.zeros(n, dtype=bool)
    is_prov[n_int:] = True
    return X, y_int, y_prov, is_prov


def _losses(net, X, yi, yp, isp):
    import torch

    oi, op = net(X)
    li = ((oi - yi) ** 2).mean(dim=1)
    lp = ((op - yp) ** 2).mean(dim=1)
    per = torch.where(isp, lp, li)
    return (
        per.mean(),
        li[~isp].mean() if (~isp).any() else li.sum() * 0,
        lp[isp].mean() if isp.any() else lp.sum() * 0,
    )


def train_aef(cfg: AEFTrainConfig, out: str | os.PathLike, progress: bool = True) -> dict:
    """Record (or reuse ``out/babbling.npz``) a babbling dataset, train, export weights.

    Writes into ``out``: ``babbling.npz``, ``checkpoint.pt`` (every epoch, atomic),
    ``aef_weights.npz`` (best epoch), ``metrics.json`` (``val_loss``, ``baseline_val_loss``,
    per-head losses, history) and ``babbling.png`` (Fig. 15).
    """
    import torch
    from tqdm import tqdm

    from neurocog_gym.train.babbling import record_babbling

    if cfg.samples < 100:
        raise ValueError(f"--samples must be at least 100, got {cfg.samples}")
    if cfg.epochs < 1:
        raise ValueError(f"--epochs must be at least 1, got {cfg.epochs}")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    data_path = out / "babbling.npz"
    babble = None
    if data_path.exists():
        try:
            with np.load(data_path) as z:
                babble = {k: z[k] for k in z.files}
            n_recorded = len(babble["command"])
        except Exception as e:  # zip, pickle or key errors of a damaged file
            raise ValueError(
                f"babbling data {data_path} is unreadable or corrupt ({_first_line(e)}); delete "
                "it to record it again, or choose another --out"
            ) from None
        if n_recorded != cfg.samples:
            babble = None
    if babble is None:
        babble = record_babbling(cfg.samples, seed=cfg.seed, progress=progress)
        import io

        buf = io.BytesIO()
        np.savez_compressed(buf, **babble)
        nio.atomic_write_bytes(data_path, buf.getvalue())
    plot_babbling(babble, out / "babbling.png")

    rng = np.random.default_rng(cfg.seed)
    X, yi, yp, isp = build_dataset(babble, rng, cfg.provision_share)
    perm = rng.permutation(len(X))
    n_val = int(len(X) * cfg.val_share)
    val, tr = perm[:n_val], perm[n_val:]
    torch.manual_seed(cfg.seed)
    net = build_torch_net(cfg.hidden)
    net.in_mean[:] = torch.as_tensor(X[tr].mean(axis=0))
    net.in_std[:] = torch.as_tensor(X[tr].std(axis=0) + 1e-6)
    T = {k: torch.as_tensor(v) for k, v in dict(X=X, yi=yi, yp=yp).items()}
    T = {k: v.float() for k, v in T.items()}
    isp_t = torch.as_tensor(isp)
    opt = torch.optim.Adam(net.parameters(), lr=cfg.lr)

    # Baseline: predict the training mean of each head's targets.
    mi = yi[tr][~isp[tr]].mean(axis=0)
    mp = yp[tr][isp[tr]].mean(axis=0)
    base_i = float(((yi[val][~isp[val]] - mi) ** 2).mean())
    base_p = float(((yp[val][isp[val]] - mp) ** 2).mean())
    base = float(
        np.where(isp[val], ((yp[val] - mp) ** 2).mean(1), ((yi[val] - mi) ** 2).mean(1)).mean()
    )

    ckpt = out / "checkpoint.pt"
    state = {"epoch": 0, "best": np.inf, "best_epoch": 0, "history": [], "bad": 0}
    perm_rng = None
    if ckpt.exists():
        try:
            saved = torch.load(ckpt, weights_only=False)
            if not isinstance(saved, dict):
                raise ValueError("not a train-aef checkpoint")
        except Exception as e:  # torch, zip and pickle errors of a damaged file
            raise ValueError(
                f"checkpoint {ckpt} is unreadable or corrupt ({_first_line(e)}); delete it to "
                "train from epoch 0, or choose another --out"
            ) from None
        if saved.get("config") == asdict(cfg):
            net.load_state_dict(saved["net"])
            opt.load_state_dict(saved["opt"])
            state = saved["state"]
            torch.set_rng_state(saved["torch_rng"])
            perm_rng = saved.get("perm_rng")
    gen = torch.Generator().manual_seed(cfg.seed + state["epoch"])
    if perm_rng is not None:
        # The batch order goes on where it stopped: a resumed run is the uninterrupted one.
        gen.set_state(perm_rng)
    bar = tqdm(
        range(state["epoch"], cfg.epochs),
        desc="train-aef",
        unit="epoch",
        disable=not progress or None,
    )
    best_weights = out / "aef_weights.npz"
    for epoch in bar:
        if state["bad"] >= cfg.patience:
            break
        net.train()
        order = torch.as_tensor(tr)[torch.randperm(len(tr), generator=gen)]
        for i in range(0, len(order), cfg.batch_size):
            b = order[i : i + cfg.batch_size]
            loss, _, _ = _losses(net, T["X"][b], T["yi"][b], T["yp"][b], isp_t[b])
            opt.zero_grad()
            loss.backward()
            opt.step()
        net.eval()
        with torch.no_grad():
            v = torch.as_tensor(val)
            vl, vi, vp = (
                float(x) for x in _losses(net, T["X"][v], T["yi"][v], T["yp"][v], isp_t[v])
            )
        state["history"].append(
            {"epoch": epoch + 1, "val_loss": vl, "val_interrupt": vi, "val_provision": vp}
        )
        if vl < state["best"] - 1e-6:
            state.update(best=vl, best_epoch=epoch + 1, bad=0)
            net.export().save(best_weights)
        else:
            state["bad"] += 1
        state["epoch"] = epoch + 1
        bar.set_postfix(val=f"{vl:.4f}", base=f"{base:.4f}")
        import io

        buf = io.BytesIO()
        torch.save({"net": net.state_dict(), "opt": opt.state_dict(), "state": state,
                    "config": asdict(cfg), "torch_rng": torch.get_rng_state(),
                    "perm_rng": gen.get_state()}, buf)  # fmt: skip
        nio.atomic_write_bytes(ckpt, buf.getvalue())
    best = (
        state["history"][state["best_epoch"] - 1] if state["best_epoch"] else state["history"][-1]
    )
    metrics = {
        "val_loss": state["best"],
        "baseline_val_loss": base,
        "ratio": state["best"] / base,
        "val_interrupt": best["val_interrupt"],
        "baseline_val_interrupt": base_i,
        "val_provision": best["val_provision"],
        "baseline_val_provision": base_p,
        "best_epoch": state["best_epoch"],
        "epochs_run": state["epoch"],
        "samples": cfg.samples,
        "config": asdict(cfg),
        "history": state["history"],
    }
    nio.atomic_write_json(out / "metrics.json", metrics)
    return metrics


def _first_line(e: BaseException) -> str:
    text = str(e).strip()
    return text.splitlines()[0] if text else type(e).__name__


def plot_babbling(babble: dict[str, np.ndarray], path: Path, leg: int = 0, n: int = 400) -> None:
    """Fig. 15: end-effector movement vectors of one leg, coloured by distance from its base."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    foot = babble["foot"][:, leg]
    v = babble["v"][:, leg]
    idx = np.linspace(0, len(foot) - 1, min(n, len(foot))).astype(int)
    dist = np.linalg.norm(foot[idx] - foot[idx].mean(axis=0), axis=1)
    fig, ax = plt.subplots(figsize=(6, 5))
    q = ax.quiver(foot[idx, 0], foot[idx, 2], v[idx, 0], v[idx, 2], dist, cmap="viridis",
                  angles="xy", scale_units="xy", scale=20, width=0.003)  # fmt: skip
    ax.scatter(foot[idx, 0], foot[idx, 2], c=dist, s=6, cmap="viridis")
    fig.colorbar(q, label="distance from the mean foot position (m)")
    ax.set_xlabel("x relative to torso (m)")
    ax.set_ylabel("z relative to torso (m)")
    ax.set_title("Motor babbling, FL foot (Fig. 15)")
    ax.set_aspect("equal")
    fig.tight_layout()
    nio.atomic_savefig(fig, path, dpi=110)
    plt.close(fig)


def write_config(path: Path, cfg: AEFTrainConfig) -> None:
    """Record the training configuration next to the results."""
    nio.atomic_write_text(path, json.dumps(asdict(cfg), indent=1))
