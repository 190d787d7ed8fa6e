"""Write the hand-designed trot gait to ``assets/default_gait.json``.

The design (which genes are non-zero and why) is by hand, following §5.1 and Fig. 12:

* every joint's flexor/extensor pair inhibits itself mutually (C1 hip, C12/C17 knee, C23/C28
  abduction): each pair is a Matsuoka half-centre oscillator;
* the hip extensor inhibits the knee flexor and the hip flexor the knee extensor (C6, C3): the
  knee folds while the hip protracts, lifting the foot in swing;
* on the leg ring FL-FR-HR-HL (structure gene 0) neighbours inhibit flexor->flexor and
  extensor->extensor (C53/C58 to the next leg, C29/C34 to the previous one): they alternate;
  the diagonal inhibits flexor->extensor (C42/C45): diagonal legs move together — a trot;
* touch sensors are not used by the default (S = 0).

The numeric values of the design parameters below were then refined by a short local random
search on flat ground (speed error to 0.5 m/s, lateral drift and cost of transport over three
seeds); ``neurocog tune-cpg`` (NSGA-II, §6.3) starts from here.

Usage: python scripts/design_gait.py [--params PARAMS.json] [--out assets/default_gait.json]
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
    hg: float = 2.9  # hip synapse m (flexor and extensor)
    kf: float = 1.48  # knee flexor synapse
    ke: float = 0.75  # knee extensor synapse
    tf: float = 1.77  # tau_f, frequency scale
    kr: float = 259.15  # restoring stiffness, 1/s^2
    zeta: float = 0.78  # restoring damping ratio
    am: float = 120.69  # theta_dd_MAX, rad/s^2
    ph: float = -0.46  # hip posture, rad
    pk: float = 1.14  # knee posture, rad
    kk: float = 0.72  # hip -> knee cross inhibition (C3, C6)
    w: float = 0.2  # neighbour inhibition (C29, C34, C53, C58)
    wb: float = 0.2  # diagonal flexor->extensor inhibition (C42, C45)
    c1: float = 2.0  # hip half-centre mutual inhibition (C1)
    kfh: float | None = None  # hind knee flexor synapse (None: as the front)
    phh: float | None = None  # hind hip posture, rad (None: as the front)
    pkh: float | None = None  # hind knee posture, rad (None: as the front)


def _or(value: float | None, default: float) -> float:
    return default if value is None else value


def build(p: TrotDesign) -> Gait:
    genes = np.zeros(N_GENES)
    genes[0] = 0.05  # ring 0: FL FR HR HL
    c = {1: p.c1, 12: 2.0, 17: 2.0, 23: 2.0, 28: 2.0, 3: p.kk, 6: p.kk}
    c.update({53: p.w, 58: p.w, 29: p.w, 34: p.w, 42: p.wb, 45: p.wb})
    for k, v in c.items():
        genes[k] = v
    return Gait(
        genes=tuple(float(v) for v in genes),
        flexor_gain=tuple([0.0, p.hg, p.kf] * 2 + [0.0, p.hg, _or(p.kfh, p.kf)] * 2),
        extensor_gain=tuple([0.0, p.hg, p.ke] * 4),
        posture=tuple([0.0, p.ph, p.pk] * 2 + [0.0, _or(p.phh, p.ph), _or(p.pkh, p.pk)] * 2),
        tau_f=p.tf,
        acc_max=p.am,
        k_rest=p.kr,
        d_rest=2.0 * p.zeta * float(np.sqrt(p.kr)),
        name="hand-designed trot",
        notes={"design": {f.name: getattr(p, f.name) for f in fields(p)}},
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--params", type=Path, help="JSON of TrotDesign fields to override")
    ap.add_argument("--out", type=Path, default=Path("assets/default_gait.json"))
    args = ap.parse_args()
    design = TrotDesign()
    if args.params:
        design = TrotDesign(**json.loads(args.params.read_text()))
    build(design).save(args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
