"""numba kernels of the locomotion generator.

Matsuoka CPG (Eq. 5-7), motor-neuron pools (Eq. 8-11) and the joint drives: pure functions over
NumPy arrays; the classes in ``cpg.py``, ``motor.py`` and ``generator.py`` own the state and call
these once per 0.01 s control cycle.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, fastmath=False)
def matsuoka_step(x, v, W, V, s, u0, b, tau, T, tau_f, dt_units, n_sub):
    """Advance the Matsuoka network in place by ``n_sub`` explicit-Euler sub-steps.

    Eq. (5): tau dx_i/dt = (u0 - x_i - sum_j W_ij y_j + sum_l V_il s_l - b v_i) tau_f
    Eq. (6): T dv_i/dt = (y_i - v_i) tau_f
    Eq. (7): y_i = max(x_i, 0)

    Args:
        x: (n,) inner states, updated in place.
        v: (n,) self-inhibition (adaptation) states, updated in place.
        W: (n, n) weight from neuron j to neuron i.
        V: (n, L) weight from sensor l to neuron i.
        s: (L,) sensor inputs.
        u0: tonic input x_0 (Table 3's u0).
        b: adaptation gain.
        tau: rise time constant, in CPG time units.
        T: adaptation time constant, in CPG time units.
        tau_f: frequency scale (multiplies both right-hand sides).
        dt_units: length of one sub-step in CPG time units.
        n_sub: number of sub-steps.

    Returns:
        (n,) the outputs y after the last sub-step.
    """
    n = x.shape[0]
    nl = s.shape[0]
    y = np.empty(n)
    sens = np.zeros(n)
    for i in range(n):
        acc = 0.0
        for k in range(nl):
            acc += V[i, k] * s[k]
        sens[i] = acc
    for _ in range(n_sub):
        for i in range(n):
            y[i] = x[i] if x[i] > 0.0 else 0.0
        for i in range(n):
            inh = 0.0
            for j in range(n):
                inh += W[i, j] * y[j]
            dx = (u0 - x[i] - inh + sens[i] - b * v[i]) * tau_f / tau
            dv = (y[i] - v[i]) * tau_f / T
            x[i] += dt_units * dx
            v[i] += dt_units * dv
    for i in range(n):
        y[i] = x[i] if x[i] > 0.0 else 0.0
    return y


@njit(cache=True)
def matsuoka_step_into(x, v, W, V, s, u0, b, tau, T, tau_f, dt_units, n_sub, out):
    """``matsuoka_step`` with the outputs y written into ``out`` (n,) (no array returned)."""
    out[:] = matsuoka_step(x, v, W, V, s, u0, b, tau, T, tau_f, dt_units, n_sub)


@njit(cache=True, inline="always")
def force_length(theta, theta_opt, width, c):
    """Eq. (9): F_l = exp(c |(theta - theta_opt) / (theta_R omega)|^3), c = ln 0.05."""
    r = abs((theta - theta_opt) / width)
    return np.exp(c * r * r * r)


@njit(cache=True, inline="always")
def force_velocity(v_muscle, v_max, K, N):
    """Eq. (10), Hill-type force-velocity factor (Geyer-Herr form, continuous at 0).

    ``v_muscle < 0`` is shortening: (v_max + v) / (v_max - K v), 1 at rest, 0 at -v_max.
    ``v_muscle >= 0`` is lengthening: N - (N - 1) (v_max - v) / (7.56 K v + v_max), 1 at rest,
    rising towards N. The paper prints both branches with sign slips that make them disagree at
    v = 0; this is the form of the Hill model it cites.
    """
    if v_muscle < 0.0:
        if v_muscle <= -v_max:
            return 0.0
        return (v_max + v_muscle) / (v_max - K * v_muscle)
    return N - (N - 1.0) * (v_max - v_muscle) / (7.56 * K * v_muscle + v_max)


@njit(cache=True)
def motor_neuron_step(
    q_ref, qd_ref, drive, theta_int, theta, theta_dot, touch, posture,
    mu1, mu2, acc_max, vel_max, fl_width, fl_c, fv_K, fv_N, Z,
    k_rest, d_rest, q_lo, q_hi, dt, acc_out, coupling, joint_lo, joint_hi, target_out,
):  # fmt: skip
    """One control cycle of the 12 motor-neuron pools (Eq. 8, 9, 10, 11), in place.

    Eq. (8): theta_dd = (mu1 y + mu2 Theta) theta_dd_MAX F_l(theta) F_v(theta_dot) + S, with y the
    CPG drive of the joint (flexor minus extensor output through the synapses m_i) and Theta the
    AEF interrupt. The CPG part of the activation is clipped to [-1, 1] and mu2 Theta is added on
    top (our reading: with mu2 > 1 an interrupt can override a saturated CPG burst; the CPG
    itself runs on untouched, Fig. 19: "the signal pattern is not influenced"). With Theta = 0
    nothing changes. Eq. (11): S = sum_l z_il s_l.
    The servos are angle-driven, so the acceleration is integrated (semi-implicit Euler) into the
    position target ``q_ref``. Our addition, not in the paper: a visco-elastic restoring term
    -k (q_ref - posture) - d q_ref_dot (the passive muscle-tendon of the pool); without it a double
    integrator of a pulse train drifts. With it each joint is a driven second-order system whose
    response to the CPG's half-wave bursts is a smooth swing, and an interrupt is a transient.
    The target rate stays within the servo speed ``vel_max`` and the target within the joint range.

    Args:
        q_ref: (12,) servo target angles, rad; updated in place.
        qd_ref: (12,) servo target rates, rad/s; updated in place.
        drive: (12,) CPG drive y of each joint, dimensionless.
        theta_int: (12,) interrupt Theta in [-1, 1] (the AEF's joint group).
        theta: (12,) measured joint angles, rad.
        theta_dot: (12,) measured joint rates, rad/s.
        touch: (4,) touch inputs s_l.
        posture: (12,) rest angles, also theta_opt of Eq. (9), rad.
        mu1: Eq. (8) gain of the CPG input.
        mu2: Eq. (8) gain of the interrupt.
        acc_max: (12,) theta_dd_MAX, rad/s^2.
        vel_max: (12,) theta_dot_MAX, rad/s.
        fl_width: (12,) Eq. (9) theta_R * omega, rad.
        fl_c: Eq. (9) c = ln 0.05.
        fv_K: Eq. (10) curvature K.
        fv_N: Eq. (10) eccentric force ratio N.
        Z: (12, 4) Eq. (11) touch weights z_il, rad/s^2.
        k_rest: restoring stiffness, 1/s^2.
        d_rest: restoring damping, 1/s.
        q_lo: (12,) lower joint limits, rad.
        q_hi: (12,) upper joint limits, rad.
        dt: control cycle, s.
        acc_out: (12,) output, the Eq. (8) acceleration (without the restoring term).
        coupling: (12,) 1 at the hip of a knee-behind leg, else 0: the pools work in leg
            coordinates (``motor.leg_coordinates``), pool angle = theta_j - coupling_j theta_j+1.
        joint_lo: (12,) lower joint limits, rad, for the servo targets.
        joint_hi: (12,) upper joint limits, rad.
        target_out: (12,) output, the servo targets in joint angles,
            q_ref_j + coupling_j q_ref_j+1 within the joint limits.
    """
    n = q_ref.shape[0]
    for i in range(n):
        th = theta[i]
        thd = theta_dot[i]
        if coupling[i] != 0.0:
            th -= coupling[i] * theta[i + 1]
            thd -= coupling[i] * theta_dot[i + 1]
        a = mu1 * drive[i]
        if a > 1.0:
            a = 1.0
        elif a < -1.0:
            a = -1.0
        a += mu2 * theta_int[i]
        # The active muscle shortens when the joint moves the way it pulls.
        v_muscle = -thd if a >= 0.0 else thd
        fl = force_length(th, posture[i], fl_width[i], fl_c)
        fv = force_velocity(v_muscle, vel_max[i], fv_K, fv_N)
        s = 0.0
        for k in range(touch.shape[0]):
            s += Z[i, k] * touch[k]
        acc = a * acc_max[i] * fl * fv + s
        acc_out[i] = acc
        acc -= k_rest * (q_ref[i] - posture[i]) + d_rest * qd_ref[i]
        qd = qd_ref[i] + acc * dt
        if qd > vel_max[i]:
            qd = vel_max[i]
        elif qd < -vel_max[i]:
            qd = -vel_max[i]
        q = q_ref[i] + qd * dt
        if q > q_hi[i]:
            q = q_hi[i]
            qd = 0.0
        elif q < q_lo[i]:
            q = q_lo[i]
            qd = 0.0
        q_ref[i] = q
        qd_ref[i] = qd
    servo_targets(q_ref, coupling, joint_lo, joint_hi, target_out)


@njit(cache=True)
def vestibular_step(qd_ref, gyro, gain, side, dt):
    """The roll reflex (our addition, ``Gait.vestibular_gain``): an Eq. (11)-type sensory term.

    Per leg l with side_l (+1 left, -1 right): the torso's roll rate ``gyro[0]`` (rad/s about
    its forward axis, positive when the right side sinks) makes the sinking side's legs
    longer and the rising side's shorter, e_l = gain (-side_l) omega_x: the knee's pool
    accelerates by -e_l (unfolds) and the hip's by +e_l / 2, so the foot keeps its direction
    from the hip (``motor.leg_coordinates``). A vestibulospinal reflex; the paper's model feeds
    body posture back into locomotion in its earlier work (§2), Eq. (11) names only touch. It
    acts on the pools' reference rate at the start of the cycle, before Eq. (8)'s integration
    (``motor_neuron_step``), as an acceleration held for one cycle.

    Args:
        qd_ref: (12,) pool reference rates, rad/s; updated in place.
        gyro: (3,) torso angular velocity in the torso's frame, rad/s.
        gain: reflex gain, 1/s (rad/s^2 of leg extension per rad/s of roll rate).
        side: (4,) +1 for a left leg, -1 for a right one (FL, FR, HL, HR).
        dt: control cycle, s.
    """
    for leg in range(side.shape[0]):
        e = gain * (-side[leg]) * gyro[0]
        qd_ref[3 * leg + 1] += 0.5 * e * dt
        qd_ref[3 * leg + 2] -= e * dt


@njit(cache=True)
def servo_targets(q_ref, coupling, joint_lo, joint_hi, target_out):
    """Pool angles to servo targets: q_ref_j + coupling_j q_ref_j+1 within the joint limits."""
    for i in range(q_ref.shape[0]):
        t = q_ref[i]
        if coupling[i] != 0.0:
            t += coupling[i] * q_ref[i + 1]
        if t > joint_hi[i]:
            t = joint_hi[i]
        elif t < joint_lo[i]:
            t = joint_lo[i]
        target_out[i] = t


@njit(cache=True)
def drive_kernel(
    y, joint_neurons, g_flex, g_ext, provision, sag_gain, brake_from, dir_gain, dir_steer,
    cor_gain, cor_front_bias, side, front, hip_joints, abduct_joints, drive, hip_drive,
):  # fmt: skip
    """Joint drives from the CPG outputs, shaped by the walking provision (``generator.py``).

    drive_j = g_flex_j y_flex(j) - g_ext_j y_ext(j); each hip's drive is scaled by the stride
    provision (s_SAG, and s_DIR left/right), and each abduction gets a side step (s_COR) and a
    steering share (s_DIR) in proportion to its hip's protraction drive. Writes ``drive`` (12,)
    and ``hip_drive`` (4,), the hips' flexor-minus-extensor outputs (swing when > 0).

    The stride scale is ``1 + sag_gain s_SAG`` down to ``s_SAG = brake_from``; below it falls
    linearly to -1 at ``s_SAG = -1`` (the brake: 0 marches in place, -1 is the trot reversed).
    """
    for j in range(drive.shape[0]):
        drive[j] = g_flex[j] * y[joint_neurons[j, 0]] - g_ext[j] * y[joint_neurons[j, 1]]
    s_sag, s_cor, s_dir = provision[0], provision[1], provision[2]
    if s_sag >= brake_from:
        stride = 1.0 + sag_gain * s_sag
    else:
        stride = -1.0 + (2.0 + sag_gain * brake_from) * (s_sag + 1.0) / (brake_from + 1.0)
    for k in range(hip_joints.shape[0]):
        h = hip_joints[k]
        a = abduct_joints[k]
        protraction = drive[h]
        drive[h] = protraction * (stride * (1.0 - dir_gain * s_dir * side[k]))
        lateral = (
            cor_gain * s_cor * (1.0 + cor_front_bias * front[k]) + dir_steer * s_dir * front[k]
        )
        drive[a] = drive[a] + -lateral * protraction
        hip_drive[k] = y[joint_neurons[h, 0]] - y[joint_neurons[h, 1]]


@njit(cache=True)
def generator_cycle(
    command, provision, a_prov, a_brake, brake_from,
    x, v, W, V, touch, u0, b, tau, T, tau_f, dt_units, n_sub, y,
    joint_neurons, g_flex, g_ext, sag_gain, dir_gain, dir_steer, cor_gain, cor_front_bias,
    side, front, hip_joints, abduct_joints, drive, hip_drive, ramp,
    q_ref, qd_ref, theta_int, theta, theta_dot, posture, mu1, mu2, acc_max, vel_max, fl_width,
    fl_c, fv_K, fv_N, Z, k_rest, d_rest, q_lo, q_hi, dt, acc_out, coupling, joint_lo, joint_hi,
    target_out, gyro, vest_gain,
):  # pragma: no cover - compiled  # fmt: skip
    """One control cycle of the whole generator (``LocomotionGenerator.step``) in one call.

    The provision's low-pass filter (the brake's on s_SAG while it or its command is below
    ``brake_from``), ``matsuoka_step_into`` ``y``, ``drive_kernel``, the soft start's ``ramp``
    factor on the drives (1.0 after the ramp: x * 1.0 is x), then ``motor_neuron_step``: the
    same operations in the same order as the separate calls, so the same bits.

    ``command`` (3,) is this cycle's walking provision, ``provision`` (3,) the filtered one
    (updated in place), ``a_prov`` = dt / max(provision_tau, dt) and ``a_brake`` =
    dt / max(brake_tau, dt) the filters' steps; ``x`` to ``y`` are ``matsuoka_step``'s
    arguments with ``y`` (24,) its output, ``joint_neurons`` to ``hip_drive`` those of
    ``drive_kernel``, and ``q_ref`` to ``target_out`` those of ``motor_neuron_step``
    (``theta_int`` the interrupt, ``touch`` shared with the CPG). With ``vest_gain`` non-zero,
    ``vestibular_step`` (torso rate ``gyro`` (3,)) runs just before the pools; at 0 it is
    skipped, and the cycle is the one of the gaits without the reflex, bit for bit.
    """
    braking = command[0] < brake_from or provision[0] < brake_from
    before = provision[0]
    for i in range(provision.shape[0]):
        provision[i] += a_prov * (command[i] - provision[i])
    if braking:
        provision[0] = before + a_brake * (command[0] - before)
    matsuoka_step_into(x, v, W, V, touch, u0, b, tau, T, tau_f, dt_units, n_sub, y)
    drive_kernel(
        y, joint_neurons, g_flex, g_ext, provision, sag_gain, brake_from, dir_gain, dir_steer,
        cor_gain, cor_front_bias, side, front, hip_joints, abduct_joints, drive, hip_drive,
    )  # fmt: skip
    if ramp != 1.0:
        for j in range(drive.shape[0]):
            drive[j] *= ramp
    if vest_gain != 0.0:
        vestibular_step(qd_ref, gyro, vest_gain, side, dt)
    motor_neuron_step(
        q_ref, qd_ref, drive, theta_int, theta, theta_dot, touch, posture, mu1, mu2, acc_max,
        vel_max, fl_width, fl_c, fv_K, fv_N, Z, k_rest, d_rest, q_lo, q_hi, dt, acc_out, coupling,
        joint_lo, joint_hi, target_out,
    )  # fmt: skip
