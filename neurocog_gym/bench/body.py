"""The body's figures: geometry, mass, servo model, and what a full swing interrupt can do.

``body_figures`` reads the compiled model (segment lengths, masses, hip height in the home pose,
servo constants). ``interrupt_lift_sweep`` measures the short-term authority the motor-neuron
pools give an interrupt (issue 21's target): the robot trots on ``NeuroCog/Walk-v3`` with the
shipped gait; at a chosen delay after a front leg's lift-off the lift interrupt (:data:`LIFT`:
knee +1, hip +0.3 on that leg, every other entry 0) is applied and held, and the sole's height
above the floor (the foot sphere's lowest point) is recorded for ``window`` seconds.

Definitions:

* lift-off: the leg's touch input drops below 0.05 (a twentieth of a quarter of the body weight)
  while the CPG is in that leg's swing phase (its hip flexor dominates), as the sudden-obstacle
  env detects it;
* peak lift: the highest sole height within ``window`` (0.15 s) of the interrupt's onset;
* time to lift: from the onset to the first control cycle with the sole at ``lift_height``
  (11 cm) or higher, or None if it is not reached within the window.

Scripted measurement tool: it reads the env's state directly (it is not a policy).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from neurocog_gym.robot.model import GRAVITY, RobotIndex, load_model

LIFT_KNEE = 1.0
"""Knee entry of the lift interrupt (fold the shank: the foot rises behind the knee)."""
LIFT_HIP = 0.3
"""Hip entry of the lift interrupt (a slight retraction keeps the foot under the hip: with the
hip protracting instead, the thigh's rise and the shank's fold cancel and the foot mostly moves
forward; scanned over -1 .. +0.3 on body v1)."""


@dataclass(frozen=True)
class LiftRow:
    """One measured interrupt of the sweep."""

    leg: int
    """0 FL or 1 FR."""
    phase: float
    """Interrupt onset as a share of that swing's duration (0 lift-off, 0.5 mid-swing)."""
    delay: float
    """Interrupt onset after lift-off, s."""
    swing_time: float
    """That swing's duration without interrupt (from the unperturbed reference run), s."""
    start_height: float
    """Sole height at the onset, m."""
    peak: float
    """Highest sole height within the window, m."""
    time_to_lift: float | None
    """Onset to the sole at the lift height, s (None: not within the window)."""


def body_figures(model: mujoco.MjModel | None = None) -> dict:
    """Geometry and mass of the robot in ``model`` (the shipped scene by default).

    Returns:
        ``thigh_m``, ``shank_m`` (joint-to-joint and knee-to-foot-centre lengths),
        ``foot_radius_m``, ``mass_kg`` (whole robot), ``torso_mass_kg`` (torso body incl. its
        geoms), ``leg_mass_kg`` (one leg: hip block, thigh, shank, foot), ``hip_height_m``
        (hip flexion axis above the floor in the ``home`` keyframe, after 1 s of standing on
        the home servo targets),
        ``stance_width_m`` (lateral distance between left and right feet), ``hip_spacing_m``
        (fore-aft distance between front and hind hips), ``servo`` (stall torque N m, kp N m/rad,
        kv N m s/rad, armature kg m^2 of the hip actuator) and ``joint_range`` per joint kind.
    """
    m = model if model is not None else load_model()
    r = RobotIndex.build(m)
    d = mujoco.MjData(m)
    key = m.key("home").id
    mujoco.mj_resetDataKeyframe(m, d, key)
    for _ in range(int(1.0 / m.opt.timestep)):
        mujoco.mj_step(m, d)
    thigh = float(np.linalg.norm(m.body_pos[r.shank_body[0]]))
    foot_geom = r.foot_geom[0]
    shank = float(np.linalg.norm(m.geom_pos[foot_geom]))
    leg_bodies = [r.hip_body[0], r.thigh_body[0], r.shank_body[0]]
    hip_z = float(d.xpos[r.thigh_body, 2].mean())
    feet = d.site_xpos[r.foot_site]
    act = r.actuator[1]
    return {
        "thigh_m": thigh,
        "shank_m": shank,
        "foot_radius_m": float(m.geom_size[foot_geom, 0]),
        "mass_kg": r.mass,
        "torso_mass_kg": float(m.body_mass[r.torso_body]),
        "leg_mass_kg": float(sum(m.body_mass[b] for b in leg_bodies)),
        "weight_n": r.mass * GRAVITY,
        "hip_height_m": hip_z,
        "stance_width_m": float(feet[[0, 2], 1].mean() - feet[[1, 3], 1].mean()),
        "hip_spacing_m": float(
            d.xpos[r.hip_body[[0, 1]], 0].mean() - d.xpos[r.hip_body[[2, 3]], 0].mean()
        ),
        "servo": {
            "stall_torque_nm": float(m.actuator_forcerange[act, 1]),
            "kp_nm_per_rad": float(m.actuator_gainprm[act, 0]),
            "kv_nms_per_rad": float(-m.actuator_biasprm[act, 2]),
            "armature_kgm2": float(m.dof_armature[r.dof_adr[1]]),
        },
        "joint_range": {
            kind: [float(v) for v in m.jnt_range[m.joint(f"FL_{kind}").id]]
            for kind in ("abduct", "hip", "knee")
        },
    }


def _sole(env, leg: int) -> float:
    r = env.unwrapped.robot
    u = env.unwrapped
    return float(u.data.site_xpos[r.foot_site[leg], 2] - u.model.geom_size[r.foot_geom[leg], 0])


def interrupt_lift_sweep(
    phases: np.ndarray,
    seeds: tuple[int, ...] = (0, 1, 2),
    legs: tuple[int, ...] = (0, 1),
    swings: int = 2,
    window: float = 0.15,
    lift_height: float = 0.11,
    settle: float = 2.0,
    env_id: str = "NeuroCog/Walk-v3",
) -> list[LiftRow]:
    """Apply the lift interrupt at each phase of front swings; one row per interrupt.

    For each seed and leg, the unperturbed run's first ``swings`` swings after ``settle`` seconds
    are found (lift-off and touch-down); each (swing, phase) pair is then replayed from the same
    seed with the interrupt held from ``lift-off + phase * swing duration`` (rounded down to a
    control cycle). Deterministic for given arguments.

    Args:
        phases: (n,) onsets as shares of the swing's duration (0.5 = mid-swing).
        seeds: env seeds.
        legs: front legs to test (0 FL, 1 FR).
        swings: lift-offs per seed and leg.
        window: s over which the peak is taken.
        lift_height: sole height the time-to-lift is measured to, m.
        settle: s of trotting before the first lift-off used.
        env_id: the walking env.
    """
    import gymnasium as gym

    rows: list[LiftRow] = []
    zero = np.zeros(15)
    for seed in seeds:
        for leg in legs:
            lifts, lands = _lift_offs(gym, env_id, seed, leg, settle, swings)
            for t_lift, t_land in zip(lifts, lands, strict=True):
                for phase in np.asarray(phases, dtype=float):
                    delay = float(phase) * (t_land - t_lift)
                    env = gym.make(env_id)
                    env.reset(seed=seed)
                    u = env.unwrapped
                    onset = t_lift + delay
                    while u.data.time < onset - 1e-9:
                        env.step(zero)
                    start = _sole(env, leg)
                    action = zero.copy()
                    action[3 * leg + 1] = LIFT_HIP
                    action[3 * leg + 2] = LIFT_KNEE
                    peak, reached = start, None
                    t0 = u.data.time
                    while u.data.time - t0 < window - 1e-9:
                        env.step(action)
                        h = _sole(env, leg)
                        peak = max(peak, h)
                        if reached is None and h >= lift_height:
                            reached = u.data.time - t0
                    env.close()
                    rows.append(
                        LiftRow(leg, float(phase), delay, t_land - t_lift, start, peak, reached)
                    )
    return rows


def _lift_offs(gym, env_id, seed, leg, settle, swings):
    """Lift-off and touch-down times of ``leg`` in the unperturbed run."""
    env = gym.make(env_id)
    env.reset(seed=seed)
    u = env.unwrapped
    zero = np.zeros(15)
    down_prev = True
    lifts: list[float] = []
    lands: list[float] = []
    while len(lands) < swings and u.data.time < settle + 5.0:
        down = bool(u.touch()[leg] > 0.05)
        t = float(u.data.time)
        if t >= settle:
            if down_prev and not down and u.generator.swinging[leg] and len(lifts) == len(lands):
                lifts.append(t)
            elif down and not down_prev and len(lifts) > len(lands):
                lands.append(t)
        down_prev = down
        env.step(zero)
    env.close()
    return lifts[: len(lands)], lands
