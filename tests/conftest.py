import os

os.environ.setdefault("MUJOCO_GL", "egl")

import warnings  # noqa: E402

import pytest  # noqa: E402


@pytest.fixture
def check_env_silently():
    """``run(env)``: stable-baselines3's ``check_env`` on ``env`` with every warning an error
    (the message then fails the test), and ``env`` closed afterwards."""

    def run(env):
        from stable_baselines3.common.env_checker import check_env

        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                check_env(env, warn=True)
        finally:
            env.close()

    return run
