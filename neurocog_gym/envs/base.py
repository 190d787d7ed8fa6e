"""QuadrupedEnv: the world, the robot and the CPG/motor-neuron stack, shared by every task.

The agent's action enters where the Affordance–Effectivity Fit's outputs enter the locomotion
generator (SPEC §1, §6): 12 joint-interrupt values Theta and 3 walking-provision values
(s_SAG, s_COR, s_DIR), all in [-1, 1]. All zeros is plain CPG walking.
"""

from __future__ import annotations

import os
from pathlib import Path

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium import spaces
from gymnasium.envs.mujoco.mujoco_env import MujocoEnv
from gymnasium.utils import EzPickle

from neurocog_gym import paths
from neurocog_gym.envs._kernels import abs_power, clip_action_groups, fault_check
from neurocog_gym.locomotion.gait import Gait, default_gait
from neurocog_gym.locomotion.generator import LocomotionGenerator
from neurocog_gym.robot.model import FAULT_WARNINGS, GRAVITY, RobotIndex, check_body
from neurocog_gym.robot.variants import bend_shanks

N_INTERRUPT = 12
N_PROVISION = 3
ACTION_DIM = N_INTERRUPT + N_PROVISION


def _check_display(render_mode: str | None) -> None:
    if render_mode == "human" and not (
        os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    ):
        raise RuntimeError(
            "render_mode='human' needs a display, and none was found (DISPLAY and "
            "WAYLAND_DISPLAY are unset). Use render_mode='rgb_array' with MUJOCO_GL=egl for "
            "headless rendering, or run under a display (e.g. xvfb-run)."
        )


class QuadrupedEnv(MujocoEnv, EzPickle):
    """Base class of the neurocog_gym tasks (see ``WalkEnv`` for the documented spaces)."""

    metadata = {"render_modes": ["human", "rgb_array", "depth_array"], "render_fps": 100}

    def __init__(
        self,
        gait: str | os.PathLike | Gait | None = None,
        target_speed: float = 0.5,
        energy_weight: float = 0.002,
        reset_noise_scale: float = 0.02,
        frame_skip: int = 5,
        render_mode: str | None = None,
        width: int = 640,
        height: int = 480,
        camera_name: str | None = "follow",
        body: str = "v2",
        **kwargs,
    ):
        EzPickle.__init__(
            self, gait, target_speed, energy_weight, reset_noise_scale, frame_skip,
            render_mode, width, height, camera_name, body=body, **kwargs,
        )  # fmt: skip
        self.body = check_body(body)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be one of {self.metadata['render_modes']} or None, "
                f"got {render_mode!r}"
            )
        _check_display(render_mode)
        if not target_speed > 0:
            raise ValueError(f"target_speed must be positive, got {target_speed}")
        if isinstance(gait, Gait):
            self.gait = gait
        elif gait is None:
            self.gait = default_gait()
        else:
            self.gait = Gait.load(Path(gait))
        self.target_speed = float(target_speed)
        self.energy_weight = float(energy_weight)
        self.reset_noise_scale = float(reset_noise_scale)

        MujocoEnv.__init__(
            self,
            str(paths.asset(paths.SCENE_XML)),
            frame_skip,
            observation_space=None,
            render_mode=render_mode,
            width=width,
            height=height,
            camera_name=camera_name,
            **kwargs,
        )
        if camera_name is not None and (
            mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_CAMERA, camera_name) < 0
        ):
            cams = [self.model.camera(i).name for i in range(self.model.ncam)]
            raise ValueError(
                f"unknown camera_name {camera_name!r}: the scene's cameras are "
                f"{', '.join(cams) or 'none'} (or None for the free camera)"
            )
        self.robot = RobotIndex.build(self.model)
        self.generator = LocomotionGenerator(
            self.gait,
            self.robot.joint_lo,
            self.robot.joint_hi,
            dt=self.dt,
            knee_behind=self.robot.knee_behind,
        )
        self._weight_per_leg = self.robot.mass * GRAVITY / 4.0
        # The joints' qpos/qvel entries, actuators and touch sensors are contiguous in the
        # model: slices read them as views (fancy indexing copies on every read).
        self._qpos_ix = _as_slice(self.robot.qpos_adr)
        self._dof_ix = _as_slice(self.robot.dof_adr)
        self._act_ix = _as_slice(self.robot.actuator)
        self._touch_ix = _as_slice(self.robot.touch_adr)
        self._cycle_dt = self.dt  # MujocoEnv.dt is a property computed on every read
        self._fault_ids = np.array([int(w) for w in FAULT_WARNINGS], dtype=np.int64)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(ACTION_DIM,), dtype=np.float32)
        self.observation_space = spaces.Dict(self._observation_spaces())
        self._power = 0.0
        self._warnings_seen = 0
        self._action_groups = 0
        """Of the last checked action: bit 0 a non-zero interrupt, bit 1 a non-zero provision."""

    # -- spaces -------------------------------------------------------------------------------

    def _observation_spaces(self) -> dict[str, spaces.Space]:
        inf = np.inf

        def box(n, lo=-inf, hi=inf):
            return spaces.Box(lo, hi, shape=(n,), dtype=np.float32)

        return {
            "joint_pos": box(12),
            "joint_vel": box(12),
            "touch": box(4, 0.0, inf),
            "torso_quat": box(4, -1.0, 1.0),
            "torso_lin_vel": box(3),
            "torso_ang_vel": box(3),
            "torso_height": box(1),
            "cpg": box(24, 0.0, inf),
            "servo_target": box(12),
        }

    # -- proprioception -----------------------------------------------------------------------

    def joint_pos(self) -> np.ndarray:
        """(12,) joint angles, rad (a copy)."""
        return self.data.qpos[self.robot.qpos_adr]

    def joint_vel(self) -> np.ndarray:
        """(12,) joint rates, rad/s (a copy)."""
        return self.data.qvel[self.robot.dof_adr]

    def touch(self) -> np.ndarray:
        """(4,) sole contact force over a quarter of the body weight (1 = a quarter's load)."""
        return self.data.sensordata[self._touch_ix] / self._weight_per_leg

    def _proprioception(self, touch: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """The proprioceptive observation; ``touch``: this cycle's :meth:`touch`, if read."""
        d = self.data
        if touch is None:
            touch = self.touch()
        torso = self.robot.torso_body
        rot = d.xmat[torso].reshape(3, 3)
        lin_vel = rot.T @ d.qvel[0:3]
        f32 = np.float32
        return {
            "joint_pos": d.qpos[self._qpos_ix].astype(f32),
            "joint_vel": d.qvel[self._dof_ix].astype(f32),
            "touch": touch.astype(np.float32),
            "torso_quat": d.qpos[3:7].astype(np.float32),
            "torso_lin_vel": lin_vel.astype(np.float32),
            "torso_ang_vel": d.qvel[3:6].astype(np.float32),
            "torso_height": d.qpos[2:3].astype(np.float32),
            "cpg": self.generator.cpg.y.astype(np.float32),
            "servo_target": self.generator.pools.target.astype(np.float32),
        }

    def _get_obs(self) -> dict[str, np.ndarray]:
        return self._proprioception()

    # -- gymnasium API --------------------------------------------------------------------------

    def reset_model(self) -> dict[str, np.ndarray]:
        """Home pose plus uniform joint noise of ``reset_noise_scale`` rad, CPG in trot phase."""
        rng = self.np_random
        qpos = self.robot.home_qpos.copy()
        qvel = np.zeros(self.model.nv)
        noise = self.reset_noise_scale
        qpos[self.robot.qpos_adr] += rng.uniform(-noise, noise, size=12)
        self.set_state(qpos, qvel)
        self.generator.reset(rng, noise=0.05)
        self.data.ctrl[self.robot.actuator] = self.generator.pools.target
        self._power = 0.0
        self._warn_stats = [self.data.warning[int(w)] for w in FAULT_WARNINGS]
        self._warnings_seen = self._warning_count()
        self._reset_task()
        return self._get_obs()

    def _reset_task(self) -> None:
        """Hook for tasks (obstacles, perception)."""

    def _check_action(self, action) -> np.ndarray:
        if (
            type(action) is np.ndarray
            and action.shape == (ACTION_DIM,)
            and action.dtype in (np.float32, np.float64)
        ):
            # The common case, checked and clipped in one compiled pass.
            a = np.empty(ACTION_DIM)
            groups = clip_action_groups(action, a, N_INTERRUPT)
            if groups >= 0:
                self._action_groups = groups
                return a
        a = np.asarray(action)
        if a.shape != (ACTION_DIM,):
            raise ValueError(
                f"action must have shape ({ACTION_DIM},) = 12 interrupts + 3 provisions, "
                f"got {a.shape}"
            )
        if not np.issubdtype(a.dtype, np.number) or np.issubdtype(a.dtype, np.complexfloating):
            raise ValueError(f"action must be real numbers, got dtype {a.dtype}")
        a = a.astype(np.float64)
        bad = ~np.isfinite(a)
        if bad.any():
            raise ValueError(f"action entries {np.flatnonzero(bad).tolist()} are NaN or inf")
        # Out-of-range values are clipped to [-1, 1] (documented in the env docstring), by the
        # fast path's kernel (np.clip's values): the clip and the groups in one pass.
        out = np.empty(ACTION_DIM)
        self._action_groups = clip_action_groups(a, out, N_INTERRUPT)
        return out

    def _warning_count(self) -> int:
        return int(sum(w.number for w in self._warn_stats))

    def _sim_unstable(self) -> bool:
        """A new fault warning, a NaN or inf position, or a NaN, inf or |qvel| > 1e3."""
        d = self.data
        unstable, self._warnings_seen = fault_check(
            d.qpos, d.qvel, d.warning.number, self._fault_ids, self._warnings_seen, 1e3
        )
        return bool(unstable)

    def _fell(self) -> bool:
        up_z = self.data.xmat[self.robot.torso_body][8]
        return bool(up_z < 0.5 or self.data.qpos[2] < 0.12)

    def _build_model(self) -> mujoco.MjModel:
        """The scene with this env's ``body`` (``robot.model.BODIES``).

        v1 is the XML as it is; v2 bends its shanks (``robot.variants.bend_shanks``). Tasks with
        their own scene override this.
        """
        if self.body == "v1":
            return mujoco.MjModel.from_xml_path(self.fullpath)
        spec = mujoco.MjSpec.from_file(self.fullpath)
        bend_shanks(spec)
        return spec.compile()

    def _initialize_simulation(self) -> tuple[mujoco.MjModel, mujoco.MjData]:
        """:meth:`_build_model`, with the offscreen buffer grown to the render size."""
        model = self._build_model()
        model.vis.global_.offwidth = max(model.vis.global_.offwidth, self.width)
        model.vis.global_.offheight = max(model.vis.global_.offheight, self.height)
        return model, mujoco.MjData(model)

    def step(self, action):
        """Advance one 0.01 s control cycle (see the task's docstring for the spaces)."""
        a = self._check_action(action)
        interrupt, provision = a[:N_INTERRUPT], a[N_INTERRUPT:]
        x_before = float(self.data.qpos[0])
        self._before_control(interrupt, provision)
        d = self.data
        target = self.generator.step(
            provision, interrupt, d.qpos[self._qpos_ix], d.qvel[self._dof_ix], self.touch(),
            d.qvel[3:6],  # the free joint's angular velocity, torso frame (the roll reflex)
        )  # fmt: skip
        ctrl = self.data.ctrl
        ctrl[self.robot.actuator] = target
        mujoco.mj_step(self.model, self.data, nstep=self.frame_skip)
        unstable = self._sim_unstable()
        if unstable:
            # Physics fault: end the episode as truncated, never raise (reset is clean).
            obs = {k: np.int64(0) if isinstance(s, spaces.Discrete) else np.zeros(s.shape, s.dtype)
                   for k, s in self.observation_space.items()}  # fmt: skip
            info = {"sim_unstable": True}
            return obs, 0.0, False, True, info
        power = abs_power(d.actuator_force[self._act_ix], d.qvel[self._dof_ix])
        self._power = power
        x_vel = (float(d.qpos[0]) - x_before) / self._cycle_dt
        self._after_physics()
        reward, terms = self._reward(x_vel, power)
        terminated = self._fell()
        info = {
            "x_position": float(self.data.qpos[0]),
            "y_position": float(self.data.qpos[1]),
            "x_velocity": x_vel,
            "power": power,
            "fell": terminated,
            "sim_unstable": False,
            **terms,
        }
        info.update(self._task_info(terminated))
        if self.render_mode == "human":
            self.render()
        return self._get_obs(), reward, terminated, False, info

    def _before_control(self, interrupt: np.ndarray, provision: np.ndarray) -> None:
        """Hook for tasks: runs before the generator step."""

    def _after_physics(self) -> None:
        """Hook for tasks: runs after the physics step (sensing, perception)."""

    def _task_info(self, terminated: bool) -> dict:
        return {}

    def _reward(self, x_vel: float, power: float) -> tuple[float, dict]:
        """Speed tracking minus energy: exp(-((v_x - v*) / (v*/2))^2) - w_E * power."""
        v = self.target_speed
        tracking = float(np.exp(-(((x_vel - v) / (0.5 * v)) ** 2)))
        energy = -self.energy_weight * power
        return tracking + energy, {"reward_tracking": tracking, "reward_energy": energy}


def _as_slice(index: np.ndarray) -> slice | np.ndarray:
    """``index`` as a slice when it is a run of consecutive integers, else unchanged."""
    index = np.asarray(index)
    if index.ndim == 1 and len(index) and (np.diff(index) == 1).all():
        return slice(int(index[0]), int(index[-1]) + 1)
    return index


def _as_stride(index: np.ndarray) -> slice | np.ndarray:
    """``index`` as a slice when it is an increasing arithmetic progression, else unchanged."""
    index = np.asarray(index)
    if index.ndim == 1 and len(index) > 1:
        step = int(index[1] - index[0])
        if step > 0 and (np.diff(index) == step).all():
            return slice(int(index[0]), int(index[-1]) + 1, step)
    return _as_slice(index)


def make_env(env_id: str, **kwargs) -> gym.Env:
    """``gymnasium.make`` with a clear error for an unknown id."""
    import neurocog_gym  # noqa: F401  (registers the ids)

    if env_id not in gym.registry:
        known = sorted(k for k in gym.registry if k.startswith("NeuroCog/"))
        raise ValueError(f"unknown env id {env_id!r}; known: {', '.join(known)}")
    return gym.make(env_id, **kwargs)
