"""numba kernels of the fast gait evaluator (``evaluate.py``).

One control cycle of the locomotion generator with an all-zero action, and the env's post-step
checks, reading and writing MuJoCo's ``MjData`` arrays in place. ``LocomotionGenerator.step``
does the same work through a dozen small NumPy calls (about 40 % of ``mj_step``'s cost on this
model); fused here it is a few microseconds.

With the walking provision and the interrupt at zero the generator's drive is
``g_flex * y_flexor - g_ext * y_extensor`` (the provision scales are exactly 1 and the coronal
term exactly 0), so these kernels reproduce ``NeuroCog/Walk-v3`` bit for bit (the evaluator's
test checks that against the env) as long as the CPG stays bounded.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from neurocog_gym.locomotion._kernels import matsuoka_step, motor_neuron_step, vestibular_step


@njit(cache=True)
def generator_cycle(
    qpos, qvel, sensordata, ctrl, qpos_adr, dof_adr, touch_adr, actuator, weight_per_leg,
    cpg_x, cpg_v, W, V, cpg_consts, n_sub, joint_neurons, g_flex, g_ext,
    q_ref, qd_ref, posture, motor_consts, acc_max, vel_max, fl_width, Z, q_lo, q_hi, dt,
    zeros12, y_out, x_max, coupling, joint_lo, joint_hi, target, gain, vest_gain, side,
):  # fmt: skip
    """One 0.01 s cycle of CPG (Eq. 5-7) and motor-neuron pools (Eq. 8-11); writes ``ctrl``.

    Args:
        qpos: MjData.qpos.
        qvel: MjData.qvel.
        sensordata: MjData.sensordata.
        ctrl: MjData.ctrl, written: the servo targets.
        qpos_adr: (12,) int, qpos address of each joint.
        dof_adr: (12,) int, qvel address of each joint.
        touch_adr: (4,) int, sensordata address of each sole's touch sensor.
        actuator: (12,) int, actuator id of each joint's servo.
        weight_per_leg: a quarter of the robot's weight, N (touch normalisation).
        cpg_x: (24,) CPG inner states, updated in place.
        cpg_v: (24,) CPG adaptation states, updated in place.
        W: (24, 24) CPG weights, from neuron j to neuron i.
        V: (24, 4) touch-sensor weights.
        cpg_consts: (6,) u0, b, tau, T, tau_f, dt_units (``MatsuokaCPG.step``'s arguments).
        n_sub: CPG Euler sub-steps.
        joint_neurons: (12, 2) int, flexor and extensor neuron of each joint.
        g_flex: (12,) signed flexor synapses.
        g_ext: (12,) signed extensor synapses.
        q_ref: (12,) servo targets, rad, updated in place.
        qd_ref: (12,) servo target rates, rad/s, updated in place.
        posture: (12,) rest angles, rad.
        motor_consts: (7,) mu1, mu2, fl_c, fv_K, fv_N, k_rest, d_rest.
        acc_max: (12,) theta_dd_MAX, rad/s^2.
        vel_max: (12,) theta_dot_MAX, rad/s.
        fl_width: (12,) Eq. (9) theta_R * omega, rad.
        Z: (12, 4) Eq. (11) touch weights.
        q_lo: (12,) lower joint limits, rad.
        q_hi: (12,) upper joint limits, rad.
        dt: control cycle, s.
        zeros12: (12,) zeros (the interrupt).
        y_out: (24,) receives the CPG outputs.
        x_max: bound on |x_i| beyond which the CPG counts as diverged.
        coupling: (12,) the pools' leg coordinates (``motor.leg_coordinates``).
        joint_lo: (12,) lower joint limits, rad (servo targets).
        joint_hi: (12,) upper joint limits, rad.
        target: (12,) receives the servo targets in joint angles (written to ``ctrl``).
        gain: the soft-start factor on the drive (``LocomotionGenerator``'s ``start_ramp``:
            ``elapsed / start_ramp`` during the ramp, then exactly 1).
        vest_gain: the gait's roll reflex gain (``Gait.vestibular_gain``), 1/s; 0 skips it.
        side: (4,) +1 for a left leg, -1 for a right one (``vestibular_step``).

    Returns:
        False, leaving ``ctrl`` untouched, when the CPG diverged (an inner state beyond
        ``x_max`` or not finite: Eq. 5 has no bound when excitatory loops win) or the servo
        targets are not finite (MuJoCo would only warn about a NaN control and zero it).
    """
    n = qpos_adr.shape[0]
    theta = np.empty(n)
    theta_dot = np.empty(n)
    for i in range(n):
        theta[i] = qpos[qpos_adr[i]]
        theta_dot[i] = qvel[dof_adr[i]]
    touch = np.empty(touch_adr.shape[0])
    for i in range(touch_adr.shape[0]):
        touch[i] = sensordata[touch_adr[i]] / weight_per_leg
    y = matsuoka_step(
        cpg_x, cpg_v, W, V, touch, cpg_consts[0], cpg_consts[1], cpg_consts[2], cpg_consts[3],
        cpg_consts[4], cpg_consts[5], n_sub,
    )  # fmt: skip
    drive = np.empty(n)
    for i in range(n):
        drive[i] = g_flex[i] * y[joint_neurons[i, 0]] - g_ext[i] * y[joint_neurons[i, 1]]
        if gain != 1.0:
            drive[i] *= gain
    if vest_gain != 0.0:
        # The free joint's angular velocity (torso frame) at the cycle's start, as the env
        # passes it to LocomotionGenerator.step.
        vestibular_step(qd_ref, qvel[3:6], vest_gain, side, dt)
    acc = np.empty(n)
    motor_neuron_step(
        q_ref, qd_ref, drive, zeros12, theta, theta_dot, touch, posture,
        motor_consts[0], motor_consts[1], acc_max, vel_max, fl_width, motor_consts[2],
        motor_consts[3], motor_consts[4], Z, motor_consts[5], motor_consts[6], q_lo, q_hi, dt, acc,
        coupling, joint_lo, joint_hi, target,
    )  # fmt: skip
    y_out[:] = y
    for i in range(n):
        if not np.isfinite(q_ref[i]):
            return False
    for i in range(cpg_x.shape[0]):
        if not abs(cpg_x[i]) <= x_max:  # also catches NaN
            return False
    for i in range(n):
        ctrl[actuator[i]] = target[i]
    return True


@njit(cache=True)
def after_step(qpos, qvel, actuator_force, xmat, warning_number, fault_warnings, n_warn_before,
               actuator, dof_adr, torso):  # fmt: skip
    """The env's post-step tests and the mechanical power.

    Returns:
        ``(status, power, n_warn)``: status 0 walking, 1 physics fault (new MuJoCo warning,
        non-finite or > 1e3 velocity), 2 fell (torso up-axis z < 0.5 or height < 0.12 m);
        power = sum |tau * omega| over the actuated joints, W; the new warning count.
    """
    n_warn = 0
    for w in fault_warnings:
        n_warn += warning_number[w]
    if n_warn > n_warn_before:
        return 1, 0.0, n_warn
    for i in range(qpos.shape[0]):
        if not np.isfinite(qpos[i]):
            return 1, 0.0, n_warn
    for i in range(qvel.shape[0]):
        if not np.isfinite(qvel[i]) or abs(qvel[i]) > 1e3:
            return 1, 0.0, n_warn
    power = 0.0
    for i in range(actuator.shape[0]):
        power += abs(actuator_force[actuator[i]] * qvel[dof_adr[i]])
    if xmat[torso, 8] < 0.5 or qpos[2] < 0.12:
        return 2, power, n_warn
    return 0, power, n_warn
