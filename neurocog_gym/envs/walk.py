"""NeuroCog/Walk-v3: the quadruped trots on flat ground on its CPG (SPEC §9)."""

from __future__ import annotations

from neurocog_gym.envs.base import QuadrupedEnv


class WalkEnv(QuadrupedEnv):
    """Flat-ground trotting with the paper's locomotion generator (§5, Fig. 6).

    ## Action space

    ``Box(-1, 1, (15,), float32)``: the AEF's output layer (Fig. 7). Values outside [-1, 1] are
    clipped; NaN or inf raise ``ValueError`` before the simulation is touched.

    | index | name | meaning |
    |---|---|---|
    | 0-11 | Theta_1..Theta_12 | joint interrupt into the motor-neuron pools (Eq. 8), joint order FL, FR, HL, HR x (abduct, hip, knee) |
    | 12 | s_SAG | sagittal speed provision (stride scale) |
    | 13 | s_COR | coronal speed provision (side step, + is left) |
    | 14 | s_DIR | direction provision (turn, + is left) |

    All zeros is plain CPG walking.

    ## Observation space

    ``Dict`` of float32 boxes:

    | key | shape | meaning |
    |---|---|---|
    | joint_pos | (12,) | joint angles, rad |
    | joint_vel | (12,) | joint rates, rad/s |
    | touch | (4,) | sole contact force / (body weight / 4) |
    | torso_quat | (4,) | torso orientation, world frame (w, x, y, z) |
    | torso_lin_vel | (3,) | torso velocity in the torso frame, m/s |
    | torso_ang_vel | (3,) | torso angular velocity in the torso frame, rad/s |
    | torso_height | (1,) | torso height above the floor, m |
    | cpg | (24,) | CPG neuron outputs y_i (Eq. 7) |
    | servo_target | (12,) | servo position targets from the motor-neuron pools, rad |

    ## Rewards (every term in ``info``)

    | term | formula |
    |---|---|
    | reward_tracking | exp(-((v_x - v*) / (v* / 2))^2), v* = ``target_speed`` |
    | reward_energy | -``energy_weight`` * sum over joints of abs(torque * rate), W |

    ## Episode end

    | condition | result |
    |---|---|
    | torso tilted over 60 degrees or lower than 0.12 m | terminated (``info["fell"]``) |
    | 2000 steps (20 s), from the registration | truncated |
    | MuJoCo warning or diverging state | truncated, ``info["sim_unstable"] = True`` |

    ## Arguments

    | argument | default | meaning |
    |---|---|---|
    | gait | None | gait file or ``Gait``; None is ``assets/default_gait.json`` |
    | target_speed | 0.5 | v*, m/s (§6.3) |
    | energy_weight | 0.002 | weight of the mechanical power, 1/W |
    | reset_noise_scale | 0.02 | uniform joint-angle noise at reset, rad |
    | frame_skip | 5 | physics steps (2 ms) per control cycle (10 ms) |
    | render_mode | None | None, "rgb_array", "depth_array", "human" |
    | width, height | 640, 480 | render size, pixels |
    | camera_name | "follow" | scene camera used to render |
    """  # noqa: E501
