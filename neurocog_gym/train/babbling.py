"""Motor babbling (§6.4, Fig. 15): random leg movements on a stand, recorded for AEF training.

The robot's torso is held 0.45 m above the floor (a stand: every foot hangs free) with the CPG
silent, and each leg receives random interrupt commands Theta (held for 50-250 ms, a third of
them zero) through its motor-neuron pools. Every control cycle records, as §6.4 lists: the
end-effector velocity v(t) (each foot's velocity in the torso frame), the previous joint angles
theta(t-1), the joint accelerations theta_dd(t-1) the pools produced, the touch condition T(t-1)
and the command Theta(t-1) that caused them.

The AEF's interrupt head is then fitted as the inverse model v(t), theta(t-1), T(t-1) -> Theta.
On the stand the soles never touch, so the touch inputs carry no information; the dataset
replaces them with uniform noise in [0, 2] so the network learns not to depend on them (our
choice, stated here; the paper does not say how touch entered its training).
"""

from __future__ import annotations

import mujoco
import numpy as np

from neurocog_gym.locomotion.gait import Gait, default_gait
from neurocog_gym.locomotion.generator import gait_motor_params
from neurocog_gym.locomotion.motor import MotorNeuronPools
from neurocog_gym.robot.model import RobotIndex, load_model

STAND_HEIGHT = 0.45


def record_babbling(
    n_samples: int, seed: int = 0, gait: Gait | None = None, progress: bool = True
) -> dict[str, np.ndarray]:
    """Record ``n_samples`` control cycles of random leg movements.

    Returns:
        dict of arrays: ``v`` (n, 4, 3) m/s, ``theta_prev`` (n, 12) rad, ``acc_prev`` (n, 12)
        rad/s^2, ``touch_prev`` (n, 4), ``command`` (n, 12) Theta in [-1, 1], ``foot`` (n, 4, 3)
        foot positions relative to the torso, m.
    """
    from tqdm import tqdm

    if n_samples < 1:
        raise ValueError(f"n_samples must be >= 1, got {n_samples}")
    gait = gait or default_gait()
    rng = np.random.default_rng(seed)
    model = load_model()
    data = mujoco.MjData(model)
    robot = RobotIndex.build(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    posture = np.asarray(gait.posture)
    mp = gait_motor_params(gait)
    pools = MotorNeuronPools(
        posture, robot.joint_lo, robot.joint_hi, mp, dt=0.01, knee_behind=robot.knee_behind
    )
    pools.reset(posture)
    data.qpos[robot.qpos_adr] = pools.target
    data.qpos[2] = STAND_HEIGHT
    pin = data.qpos[:7].copy()
    mujoco.mj_forward(model, data)
    dt = 0.01
    command = np.zeros(12)
    hold = np.zeros(4, dtype=int)
    out = {
        "v": np.zeros((n_samples, 4, 3)),
        "theta_prev": np.zeros((n_samples, 12)),
        "acc_prev": np.zeros((n_samples, 12)),
        "touch_prev": np.zeros((n_samples, 4)),
        "command": np.zeros((n_samples, 12)),
        "foot": np.zeros((n_samples, 4, 3)),
    }
    zero_drive = np.zeros(12)
    prev_foot = data.site_xpos[robot.foot_site].copy()
    for k in tqdm(range(n_samples), desc="babbling", unit="step", disable=not progress or None):
        for leg in range(4):
            if hold[leg] <= 0:
                hold[leg] = int(rng.integers(5, 26))
                c = rng.uniform(-1.0, 1.0, 3) if rng.random() > 1 / 3 else np.zeros(3)
                command[3 * leg : 3 * leg + 3] = c
            hold[leg] -= 1
        theta = data.qpos[robot.qpos_adr].copy()
        touch = data.sensordata[robot.touch_adr] / (robot.mass * 9.81 / 4)
        target = pools.step(zero_drive, command, theta, data.qvel[robot.dof_adr], touch)
        data.ctrl[robot.actuator] = target
        mujoco.mj_step(model, data, nstep=5)
        data.qpos[:7] = pin
        data.qvel[:6] = 0.0
        mujoco.mj_kinematics(model, data)
        foot = data.site_xpos[robot.foot_site].copy()
        out["v"][k] = (foot - prev_foot) / dt  # torso is level and fixed: world = torso frame
        prev_foot = foot
        out["theta_prev"][k] = theta
        out["acc_prev"][k] = pools.acc
        out["touch_prev"][k] = touch
        out["command"][k] = command
        out["foot"][k] = foot - data.qpos[:3]
    return out
