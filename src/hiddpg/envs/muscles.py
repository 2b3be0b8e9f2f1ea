"""The six muscles of the arm: length, velocity, force and joint torque.

Pure ``jnp`` functions of the joint state and a params object carrying the fields documented on
:class:`hiddpg.envs.arm.ArmParams` (``moment_arms``, ``theta0``, ``optimal_length``, ``phi``,
``omega``, ``rho``, the force-velocity constants ``v_max, c_v0, c_v1, b_v, a_v0, a_v1, a_v2``,
``velocity_sign``, ``force_scale``, the guards ``length_min, length_max, fv_min, fv_max`` and the
activation time constants). Equations are the paper's Appendix (eqs. 9–14) with the two typo
fixes of ``spec/environments.md`` §2.2:

* eq. 12 is the time derivative of eq. 11, so its sign is ``-`` (``velocity_sign = -1``);
* the numerator of eq. 14 for shortening is ``Vmax - l̇`` (the paper prints ``Vmax - l``).

Muscle order: shoulder flexor, shoulder extensor, elbow flexor, elbow extensor, biarticular
flexor, biarticular extensor.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp


def muscle_length(theta: jax.Array, p: Any) -> jax.Array:
    """Normalised muscle lengths (eq. 11), clipped to ``[length_min, length_max]``.

    ``l_i = 1 + Σ_j L_ji (θ0_ji - θ_j) / L0_i``, with ``L`` the moment arms (cm), ``θ0`` the
    optimal angles (rad) and ``L0`` the optimal lengths (cm).

    Args:
        theta: joint angles ``(θ1, θ2)`` in radians, shape ``(2,)``.
        p: arm params.

    Returns:
        shape ``(6,)``.
    """
    stretch = jnp.sum(p.moment_arms * (p.theta0 - theta[:, None]), axis=0)
    length = 1.0 + stretch / p.optimal_length
    return jnp.clip(length, p.length_min, p.length_max)


def muscle_velocity(theta_dot: jax.Array, p: Any) -> jax.Array:
    """Normalised muscle velocities (eq. 12): ``l̇_i = velocity_sign · Σ_j L_ji θ̇_j / L0_i``.

    With the default ``velocity_sign = -1`` this is the time derivative of eq. 11 (a flexor
    shortens, ``l̇ < 0``, while its joint flexes).
    """
    return p.velocity_sign * (theta_dot @ p.moment_arms) / p.optimal_length


def force_length(length: jax.Array, p: Any) -> jax.Array:
    """Force-length factor (eq. 13): ``f_l = exp(-|(l^φ - 1) / ω|^ρ)``; 1 at ``l = 1``."""
    return jnp.exp(-jnp.abs((length**p.phi - 1.0) / p.omega) ** p.rho)


def force_velocity(length: jax.Array, velocity: jax.Array, p: Any) -> jax.Array:
    """Force-velocity factor (eq. 14 with the typo fix), clipped to ``[fv_min, fv_max]``.

    Shortening (``l̇ ≤ 0``): ``(Vmax - l̇) / (Vmax + (cV0 + cV1 l) l̇)``;
    lengthening (``l̇ > 0``): ``(bV - (aV0 + aV1 l + aV2 l²) l̇) / (bV + l̇)``. Both are 1 at
    ``l̇ = 0``. Each branch is evaluated on a velocity restricted to its own side so that the
    unused branch never divides by zero (keeps gradients finite under ``jnp.where``).
    """
    shortening = jnp.minimum(velocity, 0.0)
    lengthening = jnp.maximum(velocity, 0.0)
    f_short = (p.v_max - shortening) / (p.v_max + (p.c_v0 + p.c_v1 * length) * shortening)
    a_poly = p.a_v0 + p.a_v1 * length + p.a_v2 * length**2
    f_long = (p.b_v - a_poly * lengthening) / (p.b_v + lengthening)
    f_v = jnp.where(velocity <= 0.0, f_short, f_long)
    return jnp.clip(f_v, p.fv_min, p.fv_max)


def muscle_force(
    activation: jax.Array, theta: jax.Array, theta_dot: jax.Array, p: Any
) -> jax.Array:
    """Muscle forces (eq. 9): ``F_i = a_i · f_l(l_i) · f_v(l_i, l̇_i)``, shape ``(6,)``.

    ``activation`` is used as given (the caller clips actions to ``[0, 1]``).
    """
    length = muscle_length(theta, p)
    velocity = muscle_velocity(theta_dot, p)
    return activation * force_length(length, p) * force_velocity(length, velocity, p)


def joint_torque(
    activation: jax.Array, theta: jax.Array, theta_dot: jax.Array, p: Any
) -> jax.Array:
    """Joint torques (eq. 10): ``τ = force_scale · L F`` in N·m, shape ``(2,)``."""
    return p.force_scale * (p.moment_arms @ muscle_force(activation, theta, theta_dot, p))


def filter_activation(activation: jax.Array, command: jax.Array, h: Any, p: Any) -> jax.Array:
    """One forward-Euler step of the optional first-order activation dynamics.

    ``ȧ = (u - a) / τ`` with ``τ = tau_activation`` (50 ms) when ``u > a`` and
    ``tau_deactivation`` (66 ms) otherwise [spec §2.2, decision]. The step is limited so the
    activation never overshoots the command (``h / τ`` capped at 1).

    Args:
        activation: current activation ``a``, shape ``(6,)``.
        command: the commanded activation ``u`` (clipped action), shape ``(6,)``.
        h: the integration step in seconds.
        p: arm params.
    """
    tau = jnp.where(command > activation, p.tau_activation, p.tau_deactivation)
    rate = jnp.minimum(h / tau, 1.0)
    return activation + rate * (command - activation)
