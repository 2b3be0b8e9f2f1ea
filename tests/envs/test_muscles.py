"""The muscle model (paper Appendix eqs. 9–14, spec §2.2): values, the typo fixes, the guards."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from hiddpg.envs import muscles
from hiddpg.envs.arm import ArmParams

P = ArmParams()


def _rad(*deg):
    return jnp.radians(jnp.asarray(deg, dtype=float))


def test_length_is_one_at_the_optimal_angle_and_matches_eq11():
    # shoulder flexor at its optimal shoulder angle 15° (it has no elbow moment arm)
    assert float(muscles.muscle_length(_rad(15.0, 0.0), P)[0]) == pytest.approx(1.0, abs=1e-6)
    # elbow flexor at 80.86°
    assert float(muscles.muscle_length(_rad(0.0, 80.86), P)[2]) == pytest.approx(1.0, abs=1e-6)
    # eq. 11 by hand at the start posture (45°, 90°)
    lengths = np.asarray(muscles.muscle_length(_rad(45.0, 90.0), P))
    assert lengths[0] == pytest.approx(1 + 2 * math.radians(15 - 45) / 7.32, abs=1e-6)
    biart = 1 + (1.5 * math.radians(3.9 - 45) + 2 * math.radians(92.96 - 90)) / 5.95
    assert lengths[4] == pytest.approx(biart, abs=1e-6)


def test_length_guard_clips():
    lengths = muscles.muscle_length(_rad(-2000.0, 2000.0), P)
    assert float(lengths.min()) >= P.length_min and float(lengths.max()) <= P.length_max


def test_velocity_is_the_time_derivative_of_length():
    """eq. 12 with velocity_sign = -1 is d/dt of eq. 11 (the paper's '+' is a typo)."""
    theta, theta_dot = _rad(45.0, 90.0), jnp.array([0.7, -1.3])
    _, dl_dt = jax.jvp(lambda th: muscles.muscle_length(th, P), (theta,), (theta_dot,))
    np.testing.assert_allclose(muscles.muscle_velocity(theta_dot, P), dl_dt, rtol=1e-5)
    # a flexing shoulder shortens the shoulder flexor
    assert float(muscles.muscle_velocity(jnp.array([1.0, 0.0]), P)[0]) < 0


def test_force_length_curve():
    f = lambda length: float(muscles.force_length(jnp.asarray(length), P))
    assert f(1.0) == pytest.approx(1.0)
    expected = math.exp(-abs((0.857**-1.55 - 1) / 0.81) ** 2.12)
    assert f(0.857) == pytest.approx(expected, rel=1e-5)
    assert f(0.6) < f(0.8) < f(1.0) and f(1.4) < f(1.2) < f(1.0)


def test_force_velocity_curve_and_typo_fix():
    fv = lambda length, v: float(muscles.force_velocity(jnp.asarray(length), jnp.asarray(v), P))
    assert fv(1.0, 0.0) == pytest.approx(1.0)
    assert fv(0.8, 1e-6) == pytest.approx(1.0, abs=1e-4)  # continuous at 0 on both sides
    # shortening: below 1, decreasing with speed, and 0 at l̇ = Vmax (numerator Vmax - l̇)
    assert 0 < fv(1.0, -2.0) < fv(1.0, -1.0) < 1
    assert fv(1.0, P.v_max) == pytest.approx(0.0, abs=1e-6)
    # eq. 14 by hand
    assert fv(1.0, -1.0) == pytest.approx((-7.39 + 1) / (-7.39 - (-3.21 + 4.17)), rel=1e-5)
    a = -3.12 + 4.21 * 1.1 - 2.67 * 1.1**2
    assert fv(1.1, 0.5) == pytest.approx((0.62 - a * 0.5) / (0.62 + 0.5), rel=1e-5)
    # lengthening: above 1 and guarded to fv_max
    assert 1 < fv(1.0, 0.5) <= P.fv_max
    assert fv(0.3, -3.8) <= P.fv_max and fv(2.0, 50.0) >= P.fv_min


def test_force_velocity_gradient_finite_at_the_unused_branch_pole():
    """l̇ = -b_V is a pole of the lengthening branch; it must not poison the gradient."""
    g = jax.grad(lambda v: muscles.force_velocity(jnp.asarray(1.0), v, P))(jnp.asarray(-P.b_v))
    assert np.isfinite(float(g))


def test_force_and_torque():
    theta, theta_dot = _rad(45.0, 90.0), jnp.zeros(2)
    assert np.allclose(muscles.joint_torque(jnp.zeros(6), theta, theta_dot, P), 0.0)
    act = jnp.array([1.0, 0, 0, 0, 0, 0])
    force = muscles.muscle_force(act, theta, theta_dot, P)
    length = muscles.muscle_length(theta, P)
    assert float(force[0]) == pytest.approx(float(muscles.force_length(length, P)[0]))
    tau = muscles.joint_torque(act, theta, theta_dot, P)
    assert float(tau[0]) == pytest.approx(2.0 * float(force[0]), rel=1e-6)  # L = 2 cm
    assert float(tau[1]) == 0.0
    tau2 = muscles.joint_torque(act, theta, theta_dot, P.replace(force_scale=2.0))
    np.testing.assert_allclose(tau2, 2 * tau, rtol=1e-6)
    # ~2 N·m per muscle at full activation (spec)
    assert 1.0 < float(tau[0]) < 2.5


def test_activation_filter_time_constants():
    a0, up, down = jnp.full(6, 0.5), jnp.ones(6), jnp.zeros(6)
    rise = muscles.filter_activation(a0, up, 0.01, P)
    fall = muscles.filter_activation(a0, down, 0.01, P)
    np.testing.assert_allclose(rise, 0.5 + 0.5 * 0.01 / 0.050, rtol=1e-6)
    np.testing.assert_allclose(fall, 0.5 - 0.5 * 0.01 / 0.066, rtol=1e-6)
    # a step longer than the time constant lands on the command instead of overshooting
    np.testing.assert_allclose(muscles.filter_activation(a0, up, 1.0, P), up)
