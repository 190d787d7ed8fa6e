"""The isolated step-over probe of docs/oracle_notes.md: can a front leg clear a block cleanly?

On ``NeuroCog/Walk-v3`` (trotting, no obstacle env), a block (20 cm wide, centred on the FL
lane) is placed at a front-left lift-off with its near face ``gap`` ahead of the FL sole; from
the lift-off the FL leg runs a scripted step-over, the other legs walk on. Prints, per case,
the first FL geom that touched the block (and when), where the FL foot ended relative to the
far face, and whether the torso stayed upright. The simulator is read directly: a probe of the
body, not a policy.

Primitives (``--primitive``):

* ``interrupt`` (body v1's, as the v1 oracle): lift (hip +0.3, knee +1) until the sole is 3 cm
  above the top; carry (hip -1, knee +0.5, +1 whenever the sole sinks within 1.5 cm of the top)
  until the sole is ``--beyond`` (3 cm) past the far face; release.
* ``box``: the foot tracks a box-shaped path fixed to the block (straight up for ``--t_lift`` to
  ``--apex`` above the top, forwards for ``--t_carry`` to ``--land`` past the far face, down for
  ``--t_drop``, then ``--t_stand`` holding the foot down with the leg stretched to the hip height
  ``--hip_h``); each cycle the path point, taken into the hip's frame, is turned into the leg's
  pool angles by two-segment inverse kinematics, and the interrupts are a PD law on them
  (``--kp``, ``--kd``, clipped to [-1, 1]).

``--shift`` adds an abduction interrupt on the three standing legs while the FL leg is up
(their feet move left under the body, the body right, off the lifted leg); ``--sag`` the
walking provision s_SAG.

Bodies (``--body``): ``v1`` (the shipped assets) or ``knee-behind``
(``neurocog_gym.robot.variants.knee_behind``, with ``--gait``, a ``TrotDesign`` JSON, e.g.
``docs/data/gait_knee_behind_candidate.json``).

    python scripts/stepover_probe.py [--seeds 2] [--body knee-behind --gait G.json]
        [--primitive box]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from dataclasses import dataclass, fields, replace
from pathlib import Path

import numpy as np

L, R_FOOT = 0.20, 0.018
"""Segment length and sole radius, m (assets/quadruped.xml)."""


@dataclass(frozen=True)
class Args:
    """Command-line arguments."""

    seeds: int = 2
    """Walking seeds (each runs every block case)."""
    body: str = "v1"
    """'v1' or 'knee-behind'."""
    gait: str = ""
    """TrotDesign JSON for the gait ('' = the shipped gait)."""
    primitive: str = "interrupt"
    """'interrupt' or 'box' (module docstring)."""
    beyond: float = 0.03
    """interrupt: sole past the far face before the leg is released, m."""
    lift_hip: float = 0.3
    """interrupt: hip interrupt while lifting (+: the foot swings back, as body v1's lift)."""
    lift_clear: float = 0.03
    """interrupt: sole above the top at which the lift turns into the carry, m."""
    carry_kp: float = 0.0
    """interrupt: if > 0, the carry's knee interrupt is carry_kp x (top + lift_clear - sole),
    clipped to [-1, 1] (per m; the knee unfolds when the sole is above that height), instead of
    +1 within 1.5 cm of the top and +0.5 above."""
    carry_kd: float = 0.0
    """interrupt: with ``carry_kp``, knee interrupt per m/s of the sole's vertical speed
    (subtracted: a sinking sole folds the knee)."""
    apex: float = 0.04
    """box: sole above the block's top while carried, m."""
    land: float = 0.08
    """box: sole past the far face at touch-down, m."""
    t_lift: float = 0.09
    """box: rise time, s."""
    t_carry: float = 0.16
    """box: carry time, s."""
    t_drop: float = 0.07
    """box: descent time, s."""
    t_stand: float = 0.08
    """box: time the landed leg is held stretched, s."""
    hip_h: float = 0.32
    """box: hip height the landed leg stretches to, m."""
    kp: float = 10.0
    """box: interrupt per rad of pool-angle error."""
    kd: float = 0.15
    """box: interrupt per rad/s."""
    shift: float = 0.0
    """Abduction interrupt of the three standing legs while the FL leg steps over (+: their feet
    move left under the body, the body right, away from the lifted leg)."""
    shift_fl: float = 0.0
    """Abduction interrupt of the FL leg itself while it steps over (with ``shift``: a negative
    value keeps its foot in its lane while the body moves sideways)."""
    hold_knee: float = 0.0
    """Knee interrupt of the HL leg (FL's same-side partner) while FL is held up past its nominal
    swing (0: none; negative stretches it: the HL foot stays down, so the robot stands on FR, HL
    and HR instead of only the right legs)."""
    hold_hip: float = 0.0
    """Hip interrupt of the HL leg meanwhile (with ``hold_knee``)."""
    hold_legs: str = "2"
    """Legs the hold applies to, comma-separated indices (0 FL, 1 FR, 2 HL, 3 HR; default HL)."""
    hold_from: float = 0.15
    """Seconds after FL's lift-off from which the HL hold applies."""
    any_lift: bool = False
    """Take FL's first lift-off after the settling time whatever the CPG's phase (a walk's
    knee lifts the foot before its hip flexor leads; default: only a lift-off in the CPG's
    swing, which skips the trot's flickering contacts)."""
    react: float = 0.0
    """Seconds after the lift-off at which the block appears (its near face ``gap`` ahead of
    the sole then) and the primitive starts; the swing runs as the CPG makes it until then
    (0: at the lift-off; the sudden block of the obstacle envs appears about 0.1 s after a
    front swing's start, ``scripts/sudden_placement.py``)."""
    sag: float = 0.0
    """Walking provision s_SAG for t_lift + t_carry + t_drop from the lift-off (either primitive;
    0: unchanged, -0.5: stride scale 0.7; the trot marches in place at about -0.71)."""


def leg_ik(dx: float, dz: float) -> tuple[float, float]:
    """Pool angles (hip, knee) of a two-segment leg for a foot at (dx ahead, dz up) of the hip.

    In pool coordinates (``locomotion.motor.leg_coordinates``) the foot's direction from the hip
    is -(hip + knee / 2) from straight down (a positive hip swings it back) for either knee
    direction; out-of-reach points are pulled in to the leg's full length.
    """
    d = min(float(np.hypot(dx, dz)), 2 * L - 1e-3)
    knee = 2.0 * np.arccos(d / (2 * L))
    return float(-np.arctan2(dx, -dz) - knee / 2), float(knee)


def _lift_off(gym, seed: int, settle: float = 2.0, any_lift: bool = False) -> float:
    """Time of FL's first lift-off after ``settle`` s (sole leaving 4 mm) during a CPG swing
    (any lift-off with ``any_lift``)."""
    env = gym.make("NeuroCog/Walk-v3")
    env.reset(seed=seed)
    u = env.unwrapped
    was_down = True
    while u.data.time < settle + 3.0:
        down = u.data.site_xpos[u.robot.foot_site[0], 2] - R_FOOT < 0.004
        if u.data.time > settle and was_down and not down and (any_lift or u.generator.swinging[0]):
            env.close()
            return float(u.data.time)
        was_down = down
        env.step(np.zeros(15))
    env.close()
    raise RuntimeError(f"seed {seed}: no FL lift-off within {settle + 3.0} s")


def _hold_legs(text: str) -> list[int]:
    """The legs of ``--hold_legs``; ``ValueError`` unless indices 0-3 separated by commas."""
    legs = [int(v) for v in text.split(",")]
    if not legs or any(leg not in (0, 1, 2, 3) for leg in legs):
        raise ValueError(text)
    return legs


def probe(a: Args, seed: int, t_lift: float, gap: float, height: float, length: float) -> dict:
    """One step-over from the FL lift-off at ``t_lift`` (``_lift_off``); returns the first FL
    contact, the foot past the far face and uprightness."""
    import gymnasium as gym

    from neurocog_gym.robot.obstacles import Block, ObstaclePool

    hold_legs = _hold_legs(a.hold_legs)
    env = gym.make("NeuroCog/Walk-v3")
    env.reset(seed=seed)
    u = env.unwrapped
    m, d, r = u.model, u.data, u.robot
    pool = ObstaclePool(m)
    act = np.zeros(15)
    while d.time < t_lift + a.react - 1e-9:
        env.step(act)
    t_lift = float(d.time)
    foot0 = d.site_xpos[r.foot_site[0]].copy()
    near = foot0[0] + R_FOOT + gap
    far = near + length
    pool.place(m, d, [Block(near + length / 2, foot0[1], length, 0.20, height, 0.0)])
    block = int(pool.geom_ids[0])
    fl_geoms = {int(g) for g in r.robot_geoms if m.geom(int(g)).name.startswith("FL")}
    z_apex, x_land = height + R_FOOT + a.apex, far + R_FOOT + a.land
    t_path = a.t_lift + a.t_carry + a.t_drop
    state, first, t_fall = 1, None, None
    prev_sole = float(d.site_xpos[r.foot_site[0], 2] - R_FOOT)
    over = []  # FL foot's lateral offset from the block's centre line while above the block
    for _ in range(90):
        t = d.time - t_lift
        sole = d.site_xpos[r.foot_site[0], 2] - R_FOOT
        fx = d.site_xpos[r.foot_site[0], 0]
        act[:] = 0.0
        if a.sag and 0.0 <= t < t_path:
            act[12] = a.sag
        if a.shift and 0.0 <= t < t_path:
            act[[3, 6, 9]] = a.shift
            act[0] = a.shift_fl
        if (a.hold_knee or a.hold_hip) and t >= a.hold_from and (state or t < t_path):
            for leg in hold_legs:
                act[3 * leg + 1], act[3 * leg + 2] = a.hold_hip, a.hold_knee
        if a.primitive == "interrupt" and state:
            if state == 1:
                act[1], act[2] = a.lift_hip, 1.0
                state = 2 if sole > height + a.lift_clear else 1
            elif state == 2:
                if a.carry_kp > 0:
                    rise = (sole - prev_sole) / u.dt
                    knee = a.carry_kp * (height + a.lift_clear - sole) - a.carry_kd * rise
                    knee = float(np.clip(knee, -1.0, 1.0))
                else:
                    knee = 1.0 if sole < height + 0.015 else 0.5
                act[1], act[2] = -1.0, knee
                state = 0 if fx - R_FOOT > far + a.beyond else 2
        elif a.primitive == "box" and t < t_path + a.t_stand:
            if t < a.t_lift:
                px, pz = foot0[0], R_FOOT + (z_apex - R_FOOT) * t / a.t_lift
            elif t < a.t_lift + a.t_carry:
                px, pz = foot0[0] + (x_land - foot0[0]) * (t - a.t_lift) / a.t_carry, z_apex
            else:
                px = x_land
                pz = max(R_FOOT, z_apex - (z_apex - R_FOOT) * (t - a.t_lift - a.t_carry) / a.t_drop)
            rot = d.xmat[r.torso_body].reshape(3, 3)
            rel = rot.T @ (np.array([px, foot0[1], pz]) - d.xpos[r.thigh_body[0]])
            if pz <= R_FOOT + 1e-9:
                rel[2] = min(rel[2], -(a.hip_h - R_FOOT))  # stand: stretch to the hip height
            want = leg_ik(rel[0], rel[2])
            q, qd = d.qpos[r.qpos_adr], d.qvel[r.dof_adr]
            c = 1.0 if r.knee_behind[0] else 0.0  # pool hip = hip - knee on a knee-behind leg
            have = (q[1] - c * q[2], q[2])
            rate = (qd[1] - c * qd[2], qd[2])
            for j in range(2):
                act[1 + j] = np.clip(a.kp * (want[j] - have[j]) - a.kd * rate[j], -1.0, 1.0)
        prev_sole = sole
        env.step(act)
        foot = d.site_xpos[r.foot_site[0]]
        if near - R_FOOT <= foot[0] <= far + R_FOOT:
            over.append(float(foot[1] - foot0[1]))
        for i in range(d.ncon):
            con = d.contact[i]
            if first is None and block in (con.geom1, con.geom2):
                other = con.geom2 if con.geom1 == block else con.geom1
                if other in fl_geoms:
                    first = (m.geom(other).name, round(float(d.time - t_lift), 2))
        if t_fall is None and d.xmat[r.torso_body][8] < 0.5:
            t_fall = round(float(d.time - t_lift), 2)
    beyond = float(d.site_xpos[r.foot_site[0], 0] - far)
    others = set()
    for _ in range(60):
        env.step(np.zeros(15))
        for i in range(d.ncon):
            con = d.contact[i]
            if block in (con.geom1, con.geom2):
                other = con.geom2 if con.geom1 == block else con.geom1
                if other in r.robot_geoms:
                    others.add(m.geom(other).name)
        if t_fall is None and d.xmat[r.torso_body][8] < 0.5:
            t_fall = round(float(d.time - t_lift), 2)
    upright = bool(d.xmat[r.torso_body][8] > 0.5)
    env.close()
    # Over, not round: the whole sole stayed above the top face (its centre within the half width
    # of 10 cm less the sole radius) while the foot crossed the block.
    lateral = max((abs(v) for v in over), default=np.inf)
    return {"first_touch": first, "past_far_face_m": round(beyond, 3), "upright": upright,
            "later": sorted(others), "t_fall": t_fall, "lateral_m": round(lateral, 3),
            "over": bool(lateral < 0.10 - R_FOOT)}  # fmt: skip


def _prepare_body(a: Args) -> None:
    """Point ``NEUROCOG_ASSETS`` at a temporary assets directory for the chosen body and gait."""
    if a.body == "v1" and not a.gait:
        return
    from neurocog_gym.robot.variants import knee_behind, write_assets

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from design_gait import TrotDesign, build

    out = Path(tempfile.mkdtemp(prefix="neurocog_probe_"))
    if a.body == "knee-behind":
        write_assets(knee_behind(), out)
    else:
        import mujoco

        from neurocog_gym import paths

        write_assets(mujoco.MjSpec.from_file(str(paths.asset(paths.SCENE_XML))), out)
    if a.gait:
        design = replace(TrotDesign(), **json.loads(Path(a.gait).read_text()))
        build(design).save(out / "default_gait.json")
    os.environ["NEUROCOG_ASSETS"] = str(out)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for f in fields(Args):
        if isinstance(f.default, bool):
            parser.add_argument(f"--{f.name}", action="store_true")
        else:
            parser.add_argument(f"--{f.name}", type=type(f.default), default=f.default)
    a = Args(**vars(parser.parse_args(argv)))
    if a.body not in ("v1", "knee-behind"):
        parser.error(f"--body must be 'v1' or 'knee-behind', got {a.body!r}")
    if a.primitive not in ("interrupt", "box"):
        parser.error(f"--primitive must be 'interrupt' or 'box', got {a.primitive!r}")
    if a.seeds < 1:
        parser.error("--seeds must be >= 1")
    try:
        _hold_legs(a.hold_legs)
    except ValueError:
        parser.error(
            f"--hold_legs must be leg indices 0-3 separated by commas, got {a.hold_legs!r}"
        )
    _prepare_body(a)
    import gymnasium as gym

    import neurocog_gym  # noqa: F401  (registers the env ids, after the assets are chosen)

    print("| seed | gap, cm | height, cm | length, cm | first FL touch (s after lift-off) | "
          "foot past far face, cm | upright (fell at, s) | widest sideways while crossing, cm | "
          "touched afterwards |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|")
    clean = n = 0
    skipped = []
    for seed in range(a.seeds):
        try:
            t_lift = _lift_off(gym, seed, any_lift=a.any_lift)
        except RuntimeError as e:  # a gait whose lift-offs come before its hip flexor leads
            skipped.append(f"{e} (try --any_lift)")
            continue
        for gap in (0.02, 0.04, 0.06):
            for h, length in ((0.06, 0.05), (0.08, 0.08), (0.08, 0.12)):
                res = probe(a, seed, t_lift, gap, h, length)
                touch = res["first_touch"]
                up = "yes" if res["upright"] else f"no ({res['t_fall']})"
                ok = touch is None and res["past_far_face_m"] > 0 and res["upright"] and res["over"]
                clean += ok
                n += 1
                side = res["lateral_m"] * 100
                print(f"| {seed} | {gap * 100:.0f} | {h * 100:.0f} | {length * 100:.0f} | "
                      f"{'-' if touch is None else f'{touch[0]} ({touch[1]:.2f})'} | "
                      f"{res['past_far_face_m'] * 100:.1f} | {up} | {side:.1f} | "
                      f"{', '.join(res['later']) or '-'} |")  # fmt: skip
    for line in skipped:
        print(f"\nskipped: {line}")
    print(
        f"\nclean FL step-overs (no FL touch, the sole over the top face, foot past the far "
        f"face, upright): {clean} / {n}"
    )


if __name__ == "__main__":
    main()
