"""Write the hand-designed trot gait to ``assets/default_gait.json``.

The design — which genes are non-zero and why — is by hand, following §5.1 and Fig. 12 (gene
names as in ``neurocog_gym/locomotion/chromosome.py``; "A -| B" is an inhibitory weight from
neuron A to neuron B, positive in Eq. 5; HF/HE hip flexor/extensor, KF/KE knee flexor/extensor):

* Structure gene 0.05: leg ring 0 (FL, FR, HR, HL), on which relation B (+2) is the diagonal.
* Half-centres: every joint's flexor/extensor pair inhibits itself mutually — C1 (hip, ``c1``),
  C12 and C17 (knee, 2.0), C23 and C28 (abduction, 2.0). Each pair is a Matsuoka oscillator.
* Knee a quarter cycle ahead of the hip — a four-neuron cyclic inhibition inside each leg:
  C2 (HF -| KF) and C7 (HE -| KE) with weight ``ring``, C11 (KF -| HE) and C15 (KE -| HF) with
  weight ``ring2``. A neuron that turns on shuts off the one that fired before it, so the firing
  order becomes KF -> HF -> KE -> HE: the knee flexor burst leads the hip flexor burst by about
  90 degrees. The motor-neuron pools delay hip and knee alike (a second-order low pass), so the
  knee is then most folded in mid-swing, when the hip protracts fastest, and stretched in
  mid-stance: the foot rises in swing. The earlier design coupled the knee in phase with the hip
  (C3, C6 alone); the knee then folded most at the end of swing and the foot slid forward on an
  almost flat line (hind feet 0-2 mm off the ground).
* C3 (HF -| KE, ``kk``) and C6 (HE -| KF, ``kk6``): the old in-phase hip-to-knee pull, kept as a
  small trim of the knee's phase lead (it pulls the knee towards the hip's phase).
* Inter-leg, on the ring: neighbours inhibit flexor -| flexor and extensor -| extensor — C53, C58
  to the next leg and C29, C34 to the previous one (``w``): neighbours alternate; the diagonal
  inhibits flexor -| extensor and extensor -| flexor — C42, C45 (``wb``): diagonals move
  together. Together: a trot, diagonal pairs in phase, the pairs in anti-phase.
* Touch sensors are not used (S = 0): touch-to-hip weights (S1, S2, S9, S10) of +-0.3 already
  broke the trot (the touch inputs reach 3-5 at touchdown); left to NSGA-II.
* Synapses m_i: hip flexor = extensor (``hg`` front, ``hgh`` hind); knee flexor ``kf``/``kfh`` and
  a weaker knee extensor ``ke``/``keh`` (the knee folds actively and is stretched mostly by the
  pool's restoring term); abduction 0 — the abduction pools carry only the side-step/steering
  provision (``generator.py``) and the AEF's interrupt.
* Posture (the centre of the oscillation and theta_opt of Eq. 9): front hip ``ph`` / knee ``pk``,
  hind ``phh`` / ``pkh``, and the abduction posture ``pa`` (feet outward for pa > 0). The search
  left ``pa`` at -0.006 rad (feet 1 mm inward): tiny, but it trims the slow sideways crab of the
  open-loop trot, whose direction flips between pa = -0.006 and pa = 0.

Numeric values (body v1, issue 21): the structure above is the v0 design, unchanged. The numbers
of ``TrotDesign`` (synapses, tau_f, k_rest, theta_dd_MAX, posture) were found again on the v1 body
by a single-process local random search on ``NeuroCog/Walk-v3`` (zero action, 2-3 seeds of 8 s,
the first 2 s left out, one or two numbers perturbed by 6 % at a time and kept when better),
starting from the v0 numbers scaled to the longer legs (theta_dd_MAX x 0.55, tau_f x 1.3, knee
synapses x 0.7, posture hip -0.8 / knee 1.6). Its cost: speed error to 0.5 m/s; every leg's
median swing clearance outside 3.2-4.8 cm and any swing above 5.8 cm; lateral drift; a fall
(100); the share of time with both feet of one side in the air (x 20: the first searches, without
it, found a pace-like gait with that share at 0.53, which tipped over whenever a front swing was
held); short touch-downs of under 80 ms. About 1,100 candidates in four rounds. The chromosome's
genes were not searched; ``neurocog tune-cpg`` (NSGA-II, §6.3, Table 3) tunes them from this gait.
Measured numbers are in ``docs/generated/benchmarks_walk.md`` (``scripts/bench_walk.py``) and
``docs/body.md`` (``scripts/body_figures.py``).

Usage: python scripts/design_gait.py [--params PARAMS.json] [--notes NOTES.json]
       [--out assets/default_gait.json]
"""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from neurocog_gym.locomotion.chromosome import N_GENES
from neurocog_gym.locomotion.gait import Gait


@dataclass
class TrotDesign:
    """Numbers of the hand design (module docstring); defaults are the shipped gait."""

    hg: float = 2.9995
    """m_i of the front hip flexor and extensor."""
    hgh: float = 2.0442
    """m_i of the hind hip flexor and extensor."""
    kf: float = 1.4316
    """m_i of the front knee flexor."""
    ke: float = 0.0
    """m_i of the front knee extensor."""
    kfh: float = 1.1075
    """m_i of the hind knee flexor."""
    keh: float = 0.6799
    """m_i of the hind knee extensor."""
    tf: float = 0.5960
    """tau_f, CPG frequency scale."""
    kr: float = 275.1260
    """k_rest, restoring stiffness of the pools, 1/s^2."""
    zeta: float = 0.7545
    """Damping ratio of the pools' restoring term (d_rest = 2 zeta sqrt(k_rest))."""
    am: float = 104.5131
    """theta_dd_MAX, rad/s^2 (Eq. 8)."""
    vm: float = 6.6
    """theta_dot_MAX, rad/s (Eq. 10): the servo's no-load speed (6.6: the shipped MX-64; a
    faster servo, ``robot.variants.servo_speed``, needs its figure here)."""
    vg: float = 20.0
    """Roll reflex gain, 1/s (``Gait.vestibular_gain``; the env v3 default: 20, chosen on
    training trials, ``docs/locomotion.md``; 0 is the v2 gait)."""
    ph: float = -0.8963
    """Front hip posture, rad."""
    pk: float = 1.4801
    """Front knee posture, rad."""
    phh: float = -0.6926
    """Hind hip posture, rad."""
    pkh: float = 1.2632
    """Hind knee posture, rad."""
    pa: float = -0.0061
    """Abduction posture, rad, feet outward (left legs +, right legs -)."""
    c1: float = 2.1427
    """C1, hip half-centre mutual inhibition."""
    ring: float = 0.7541
    """C2 (HF -| KF) and C7 (HE -| KE): knee-ahead ring, hip to knee."""
    ring2: float = 1.1593
    """C11 (KF -| HE) and C15 (KE -| HF): knee-ahead ring, knee to hip."""
    kk: float = 0.2001
    """C3 (HF -| KE): in-phase trim."""
    kk6: float = -0.4608
    """C6 (HE -| KF): in-phase trim (negative: excitatory)."""
    w: float = 0.0646
    """C29, C34, C53, C58: neighbour inhibition (alternation)."""
    wb: float = 0.1982
    """C42, C45: diagonal flexor -| extensor inhibition (diagonal pairs together)."""
    t_hf: float = 0.0
    """S1, own touch sensor -> hip flexor (negative: a loaded foot holds its swing back)."""
    t_he: float = 0.0
    """S2, own touch sensor -> hip extensor (positive: a loaded foot pushes on)."""
    t_kf: float = 0.0
    """S3, own touch sensor -> knee flexor (negative: a loaded knee does not fold)."""
    t_nf: float = 0.0
    """S7 and S11, a ring neighbour's touch sensor -> hip flexor (negative, excitatory: a leg
    swings sooner while the legs beside it on the ring carry load, and waits while one of them
    is still in the air; Cruse's "a leg does not lift before its neighbour is down")."""
    t_ne: float = 0.0
    """S8 and S12, a ring neighbour's touch sensor -> hip extensor."""
    walk: bool = False
    """A lateral-sequence walk instead of the trot (FL, HR, FR, HL one after the other, a
    quarter cycle apart; the paper's robot walks in the static-obstacle trials, §6.5.2): the
    structure gene picks ring 5 (FL HR FR HL), on which relation B is the contralateral pair;
    ``w``/``wb`` are then unused and ``wa``, ``wc``, ``wbw`` set the ring's couplings."""
    wa: float = 0.0
    """Walk: C53, C58, flexor -| flexor and extensor -| extensor to the next leg on the ring."""
    wc: float = 0.3
    """Walk: C29, C34, the same to the previous leg on the ring (wc > wa: each leg lags the one
    before it on the ring by a quarter cycle; wa > wc reverses the sequence)."""
    wbw: float = 0.3
    """Walk: C41, C46, flexor -| flexor and extensor -| extensor across (the front pair and the
    hind pair alternate)."""


def build(p: TrotDesign) -> Gait:
    """The gait of design ``p``."""
    genes = np.zeros(N_GENES)
    genes[0] = 5 / 6 + 0.05 if p.walk else 0.05  # ring 5 (walk) or ring 0: B the diagonal
    c = {1: p.c1, 12: 2.0, 17: 2.0, 23: 2.0, 28: 2.0}  # half-centres
    c.update({2: p.ring, 7: p.ring, 11: p.ring2, 15: p.ring2})  # knee-ahead ring
    c.update({3: p.kk, 6: p.kk6})  # in-phase trim
    if p.walk:
        c.update({53: p.wa, 58: p.wa, 29: p.wc, 34: p.wc, 41: p.wbw, 46: p.wbw})
    else:
        c.update({53: p.w, 58: p.w, 29: p.w, 34: p.w, 42: p.wb, 45: p.wb})  # trot
    for k, v in c.items():
        genes[k] = v
    genes[65:68] = p.t_hf, p.t_he, p.t_kf  # S1, S2, S3: the load rule (body v2)
    genes[71:73] = p.t_nf, p.t_ne  # S7, S8: touch of ring leg l -> hip neurons of leg l + 3
    genes[75:77] = p.t_nf, p.t_ne  # S11, S12: ... of leg l + 1 (both ring neighbours alike)
    front_posture = [p.ph, p.pk]
    hind_posture = [p.phh, p.pkh]
    return Gait(
        genes=tuple(float(v) for v in genes),
        flexor_gain=(0.0, p.hg, p.kf) * 2 + (0.0, p.hgh, p.kfh) * 2,
        extensor_gain=(0.0, p.hg, p.ke) * 2 + (0.0, p.hgh, p.keh) * 2,
        posture=tuple(
            float(v)
            for v in [p.pa, *front_posture, -p.pa, *front_posture]
            + [p.pa, *hind_posture, -p.pa, *hind_posture]
        ),
        tau_f=p.tf,
        acc_max=p.am,
        vel_max=p.vm,
        vestibular_gain=p.vg,
        k_rest=p.kr,
        d_rest=2.0 * p.zeta * float(np.sqrt(p.kr)),
        name="hand-designed walk" if p.walk else "hand-designed trot",
        notes={"design": {f.name: getattr(p, f.name) for f in fields(p)}},
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--params", type=Path, help="JSON of TrotDesign fields to override")
    ap.add_argument("--notes", type=Path, help="JSON merged into the gait's notes (measurements)")
    ap.add_argument("--out", type=Path, default=Path("assets/default_gait.json"))
    args = ap.parse_args()
    design = TrotDesign()
    if args.params:
        design = TrotDesign(**json.loads(args.params.read_text()))
    gait = build(design)
    if args.notes:
        gait.notes.update(json.loads(args.notes.read_text()))
    gait.save(args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
