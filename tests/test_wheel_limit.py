"""The burger's wheel limits (env.wheel_limit): each command as its firmware drives it.

References are worked out by hand from ROBOTIS' OpenCR firmware (ROS 1, master
68ec75d8): commands clipped to +-0.033 * 2 pi * 61 / 60 = +-0.21080 m/s and
+-0.21080 / 0.08 = +-2.63501 rad/s, then each wheel (v -/+ 0.08 omega) to 265
Dynamixel units of 0.033 / 41.69988758 m/s, i.e. +-0.2097128 m/s.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from _nav_reference import displacement as reference_displacement

import jaxnav
from jaxnav.core.config import ConfigError, load_config
from jaxnav.env import from_config
from jaxnav.world.kinematics import firmware_limit

WHEEL_MAX = 265 * 0.033 / 41.69988758  # m/s, by hand: 0.2097128

# The paper's five actions at 0.15 m/s: (omega) -> (v, omega) driven. The turns of
# +-0.75 rad/s ask 0.15 + 0.06 = 0.21 m/s of the outer wheel, just over 0.2097; the
# turns of +-1.5 rad/s ask 0.27 m/s. Inner wheel 0.15 - 0.08 |omega| is within limits.
PAPER_ACTIONS = {
    -1.5: ((0.03 + WHEEL_MAX) / 2, -(WHEEL_MAX - 0.03) / 0.16),  # (0.11986, -1.12320)
    -0.75: ((0.09 + WHEEL_MAX) / 2, -(WHEEL_MAX - 0.09) / 0.16),  # (0.14986, -0.74820)
    0.0: (0.15, 0.0),
    0.75: ((0.09 + WHEEL_MAX) / 2, (WHEEL_MAX - 0.09) / 0.16),
    1.5: ((0.03 + WHEEL_MAX) / 2, (WHEEL_MAX - 0.03) / 0.16),
}


def test_the_hand_computed_wheel_limit_is_0_2097_m_per_s():
    assert WHEEL_MAX == pytest.approx(0.2097128, abs=1e-7)
    assert PAPER_ACTIONS[1.5] == pytest.approx((0.1198564, 1.1232050), abs=1e-7)
    assert PAPER_ACTIONS[0.75] == pytest.approx((0.1498564, 0.7482050), abs=1e-7)


@pytest.mark.parametrize("omega", sorted(PAPER_ACTIONS))
def test_each_paper_action_is_clipped_as_by_hand(omega):
    v_want, w_want = PAPER_ACTIONS[omega]
    v, w = firmware_limit(np.float64(0.15), np.float64(omega))
    assert (float(v), float(w)) == pytest.approx((v_want, w_want), abs=1e-9)
    # The same function on JAX arrays, as the compiled step calls it (float32).
    vj, wj = firmware_limit(jnp.float32(0.15), jnp.float32(omega))
    assert (float(vj), float(wj)) == pytest.approx((v_want, w_want), abs=1e-6)


@pytest.mark.parametrize(
    "command, driven",
    [
        # Over the linear limit: clipped to 0.2108, then both wheels to 0.2097.
        ((0.3, 0.0), (WHEEL_MAX, 0.0)),
        ((-0.3, 0.0), (-WHEEL_MAX, 0.0)),
        # Over the angular limit: 2.635 rad/s, wheels -/+0.2108, then -/+0.2097.
        ((0.0, 4.0), (0.0, 2 * WHEEL_MAX / 0.16)),
        # Both steps at once: omega clipped to 2.63501 first (half 0.21080), so the
        # wheels are 0.1 -/+ 0.21080 = (-0.11080, 0.31080) -> (-0.11080, 0.20971).
        ((0.1, 3.0), ((0.1 - 0.2108009 + WHEEL_MAX) / 2, (WHEEL_MAX - 0.1 + 0.2108009) / 0.16)),
        # Within every limit: unchanged.
        ((0.1, -1.0), (0.1, -1.0)),
    ],
)
def test_commands_go_through_the_command_clip_then_the_wheel_clip(command, driven):
    v, w = firmware_limit(np.float64(command[0]), np.float64(command[1]))
    assert (float(v), float(w)) == pytest.approx(driven, abs=1e-6)


def _step_from(env, params, pos, yaw, action):
    _, state = env.reset(jax.random.PRNGKey(0), params)
    state = state.replace(pos=jnp.asarray(pos, jnp.float32), yaw=jnp.asarray(yaw, jnp.float32))
    _, new, _, terminated, _, info = env.step_env(jax.random.PRNGKey(1), state, action, params)
    return np.asarray(new.pos, np.float64), float(new.yaw), bool(terminated)


@pytest.mark.parametrize("action", range(5))
@pytest.mark.parametrize("limited", [True, False])
def test_the_robot_moves_along_the_arc_of_the_driven_velocities(action, limited):
    """One step from the middle of square4: the pose is a NumPy unicycle's, integrated
    by quadrature, at the hand-computed (v, omega) with the limit and at the commanded
    (0.15, omega) without it."""
    env, params = jaxnav.make("square4", wheel_limit=limited)
    omega = float(params.omegas[action])
    v, w = PAPER_ACTIONS[omega] if limited else (0.15, omega)
    pos0, yaw0 = np.array([0.3, -0.2]), 0.4
    pos, yaw, collided = _step_from(env, params, pos0, yaw0, action)
    assert not collided
    np.testing.assert_allclose(pos, pos0 + reference_displacement(yaw0, w, v, 0.2), atol=2e-6)
    assert yaw == pytest.approx(yaw0 + w * 0.2, abs=2e-6)


def test_with_the_limit_a_turn_covers_less_ground_and_less_angle():
    on, p_on = jaxnav.make("square4", wheel_limit=True)
    off, p_off = jaxnav.make("square4")
    pos_on, yaw_on, _ = _step_from(on, p_on, (0.0, 0.0), 0.0, 4)  # +1.5 rad/s
    pos_off, yaw_off, _ = _step_from(off, p_off, (0.0, 0.0), 0.0, 4)
    assert yaw_off - yaw_on == pytest.approx(0.2 * (1.5 - 1.1232050), abs=1e-5)
    assert np.linalg.norm(pos_on) < np.linalg.norm(pos_off) - 0.005


def test_the_collision_check_follows_the_driven_arc():
    """Facing square4's east wall (x = 1.85), turning at +1.5 rad/s: the commanded arc
    advances r sin(0.3) = 0.02955 m (r = 0.1 m), the driven one 0.10671 sin(0.22464) =
    0.02377 m. With the wall 0.13 + 0.0266 m ahead the first touches it (the 0.13 m
    disc), the second does not."""
    pos = (1.85 - 0.13 - 0.0266, 0.0)
    off, p_off = jaxnav.make("square4")
    on, p_on = jaxnav.make("square4", wheel_limit=True)
    assert _step_from(off, p_off, pos, 0.0, 4)[2]
    assert not _step_from(on, p_on, pos, 0.0, 4)[2]


def test_off_by_default_and_off_changes_nothing():
    cfg = load_config("smoke")
    assert cfg.env.wheel_limit is False
    env, _ = from_config(cfg)
    assert env.wheel_limit is False
    env_on, _ = from_config(load_config("smoke", ["env.wheel_limit=true"]))
    assert env_on.wheel_limit is True
    a, pa = jaxnav.make("square4_obstacles")
    b, pb = jaxnav.make("square4_obstacles", wheel_limit=False)
    for action in range(5):
        sa, sb = (
            _step_from(a, pa, (0.3, 0.1), 1.0, action),
            _step_from(b, pb, (0.3, 0.1), 1.0, action),
        )
        assert sa[0].tobytes() == sb[0].tobytes() and sa[1:] == sb[1:]


def test_a_bad_value_names_the_setting():
    with pytest.raises(ConfigError, match="env.wheel_limit"):
        load_config("smoke", ["env.wheel_limit=3"])


def test_the_mujoco_burger_drives_the_clipped_command():
    """The MuJoCo burger with the limit sets its servos for the driven (v, omega) and
    turns at about its rate (1.123 rad/s, not 1.5) through wheel physics."""
    pytest.importorskip("mujoco", reason="MuJoCo is not installed (pip install mujoco)")
    from jaxnav.robot.mujoco_model import wheel_speeds
    from jaxnav.robot.mujoco_rollout import Burger
    from jaxnav.world.maps import make_maze

    robot = Burger(make_maze("square8"), wheel_limit=True)
    robot.place(0.0, 0.0, 0.0)
    v, w = PAPER_ACTIONS[1.5]
    assert robot.command(0.15, 1.5) == pytest.approx((v, w), abs=1e-9)
    np.testing.assert_allclose(robot.data.ctrl, wheel_speeds(v, w), atol=1e-9)
    assert max(abs(c) for c in robot.data.ctrl) * 0.033 == pytest.approx(WHEEL_MAX, abs=1e-9)
    yaws = []
    for _ in range(8):
        assert not robot.drive(0.15, 1.5, 0.2)
        yaws.append(robot.pose()[2])
    rate = np.diff(np.unwrap(yaws)) / 0.2
    assert rate[2:].mean() == pytest.approx(w, rel=0.05)
    assert abs(rate[2:].mean() - 1.5) > 0.3
    free = Burger(make_maze("square8"))
    assert free.command(0.15, 1.5) == (0.15, 1.5)
    assert math.isclose(free.data.ctrl[1] * 0.033, 0.27)
