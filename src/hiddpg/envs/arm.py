"""The two-joint, six-muscle planar arm: params, skeleton dynamics, kinematics, obstacle distance.

Spec: ``spec/environments.md`` §2.1–2.3; paper Appendix eq. 8 (skeleton) and eqs. 9–14 (muscles,
in :mod:`hiddpg.envs.muscles`). State ``x = [θ1, θ2, θ̇1, θ̇2]``: shoulder angle from the +x axis,
elbow angle relative to the upper arm (0 = straight), in radians and rad/s. No gravity.

Everything here is a pure function of ``(x, activation, params)``: ``jit``, ``vmap`` (over states
or over params, e.g. the three force fields via :func:`stack_params`) and ``jax.jacrev`` work.

[decision] marks a value of ours where the paper is silent; docs/environments.md (its tables of
constants, each tagged) lists them.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

from hiddpg.envs.base import check_choice, check_range, replace_params
from hiddpg.envs.muscles import (
    filter_activation,
    force_length,
    force_velocity,
    joint_torque,
    muscle_length,
    muscle_velocity,
)

#: The joint friction / force-field matrix ``B`` for each ``field`` (paper Appendix, eq. 8).
FIELD_FRICTION: dict[str, tuple[tuple[float, float], tuple[float, float]]] = {
    "none": ((0.05, 0.0), (0.0, 0.05)),
    "cw": ((0.0, 0.05), (-0.05, 0.0)),
    "ccw": ((0.0, -0.05), (0.05, 0.0)),
}


def _array(value: Any) -> Any:
    """A dataclass default factory building a float array (dtype follows the x64 setting)."""
    return struct.field(default_factory=lambda: jnp.asarray(value, dtype=float))


@struct.dataclass
class ArmParams:
    """Every constant of the arm (spec §2.1–2.2); tags [paper] / [source] / [decision] there.

    Skeleton [source, Li & Todorov 2004]:
        upper_arm_length, forearm_length: ``l1 = 0.30``, ``l2 = 0.33`` m.
        forearm_com: forearm centre of mass from the elbow, ``s2 = 0.16`` m.
        forearm_mass: ``m2 = 1.0`` kg.
        upper_arm_inertia, forearm_inertia: ``I1 = 0.025``, ``I2 = 0.045`` kg m² about the joints.
        field: force field name, ``"none" | "cw" | "ccw"`` (static).
        friction: the matrix ``B`` of eq. 8 (N m s/rad), :data:`FIELD_FRICTION` ``[field]``.
        physics_dt: forward-Euler step, 0.01 s [decision].
        frame_skip: physics steps per action (static), 2, so the control period is 0.02 s.
        joint_low, joint_high: joint limits, ``(0°, 0°)`` and ``(140°, 160°)``, stored in rad.

    Muscles [paper Appendix]:
        moment_arms: ``L`` (cm), rows shoulder / elbow, columns the six muscles.
        theta0: optimal angles ``θ0`` in rad (the paper prints degrees: shoulder
            ``[15.0, 5.02, 0, 0, 3.9, 2.12]``, elbow ``[0, 0, 80.86, 109.32, 92.96, 91.52]``).
        optimal_length: ``L0`` (cm), ``[7.32, 3.26, 6.4, 3.26, 5.95, 4.06]``.
        phi, omega, rho: force-length constants of eq. 13 (``φ = -1.55`` as in the paper;
            public code uses +1.55).
        v_max, c_v0, c_v1, b_v, a_v0, a_v1, a_v2: force-velocity constants of eq. 14.
        velocity_sign: sign of eq. 12; -1 makes it the derivative of eq. 11 [decision, typo fix].
        force_scale: factor on eq. 10, ``τ = force_scale · L F`` in N·m [decision].
        length_min, length_max: guard on ``l``, ``[0.3, 2.0]`` [decision].
        fv_min, fv_max: guard on ``f_v``, ``[0, 1.8]`` [decision].
        activation_filter: first-order activation dynamics on/off (static), off [decision].
        tau_activation, tau_deactivation: its time constants, 0.050 s and 0.066 s.
    """

    upper_arm_length: float = 0.30
    forearm_length: float = 0.33
    forearm_com: float = 0.16
    forearm_mass: float = 1.0
    upper_arm_inertia: float = 0.025
    forearm_inertia: float = 0.045
    field: str = struct.field(pytree_node=False, default="none")
    friction: jax.Array = _array(FIELD_FRICTION["none"])
    physics_dt: float = 0.01
    frame_skip: int = struct.field(pytree_node=False, default=2)
    joint_low: jax.Array = _array((0.0, 0.0))
    joint_high: jax.Array = _array((math.radians(140.0), math.radians(160.0)))
    moment_arms: jax.Array = _array(((2.0, -2.0, 0.0, 0.0, 1.5, -2.0),
                                     (0.0, 0.0, 2.0, -2.0, 2.0, -1.5)))
    theta0: jax.Array = _array(tuple(tuple(math.radians(v) for v in row) for row in (
        (15.0, 5.02, 0.0, 0.0, 3.9, 2.12), (0.0, 0.0, 80.86, 109.32, 92.96, 91.52))))
    optimal_length: jax.Array = _array((7.32, 3.26, 6.4, 3.26, 5.95, 4.06))
    phi: float = -1.55
    omega: float = 0.81
    rho: float = 2.12
    v_max: float = -7.39
    c_v0: float = -3.21
    c_v1: float = 4.17
    b_v: float = 0.62
    a_v0: float = -3.12
    a_v1: float = 4.21
    a_v2: float = -2.67
    velocity_sign: float = -1.0
    force_scale: float = 1.0
    length_min: float = 0.3
    length_max: float = 2.0
    fv_min: float = 0.0
    fv_max: float = 1.8
    activation_filter: bool = struct.field(pytree_node=False, default=False)
    tau_activation: float = 0.050
    tau_deactivation: float = 0.066


# -- construction and validation --------------------------------------------------------------
_POSITIVE = ("upper_arm_length", "forearm_length", "forearm_com", "forearm_mass",
             "upper_arm_inertia", "forearm_inertia", "physics_dt", "omega", "rho", "b_v",
             "force_scale", "length_min", "tau_activation", "tau_deactivation")


def build_params(defaults: Any, overrides: dict[str, Any]) -> Any:
    """Apply ``overrides`` to ``defaults`` (an :class:`ArmParams` or subclass) and validate the
    arm fields. Array fields are converted and shape-checked; ``field`` also sets ``friction``
    unless ``friction`` is given too. Errors name the parameter."""
    overrides = dict(overrides)
    if "field" in overrides:
        check_choice("field", overrides["field"], tuple(FIELD_FRICTION))
        overrides.setdefault("friction", FIELD_FRICTION[overrides["field"]])
    known = {f.name for f in dataclasses.fields(defaults)}
    for name, value in overrides.items():
        default = getattr(defaults, name) if name in known else None
        if isinstance(default, jax.Array):
            value = jnp.asarray(value, dtype=float)
            if value.shape != default.shape:
                raise ValueError(f"{name} must have shape {default.shape}, got {value.shape}")
            if not bool(jnp.all(jnp.isfinite(value))):
                raise ValueError(f"{name}={value} must be finite")
            overrides[name] = value
    params = replace_params(defaults, overrides)
    validate_arm(params)
    return params


def validate_arm(p: ArmParams) -> None:
    """Raise ``ValueError`` naming the first invalid arm field."""
    check_choice("field", p.field, tuple(FIELD_FRICTION))
    for name in _POSITIVE:
        check_range(name, getattr(p, name), 0.0, strict_low=True)
    check_choice("velocity_sign", float(p.velocity_sign), (-1.0, 1.0))
    if not isinstance(p.frame_skip, int) or p.frame_skip < 1:
        raise ValueError(f"frame_skip={p.frame_skip!r} must be an int >= 1")
    if not isinstance(p.activation_filter, bool):
        raise ValueError(f"activation_filter={p.activation_filter!r} must be a bool")
    check_range("length_max", p.length_max, p.length_min, strict_low=True)
    check_range("fv_max", p.fv_max, p.fv_min, strict_low=True)
    if not bool(jnp.all(p.joint_low < p.joint_high)):
        raise ValueError(f"joint_low={p.joint_low} must be below joint_high={p.joint_high}")


def stack_params(params_seq: Any) -> Any:
    """Stack params (e.g. the three force fields) along a new leading axis for ``jax.vmap``.

    Static fields must agree, except ``field``, which becomes the names joined by ``"|"``
    (the per-member ``friction`` matrices carry the physics).
    """
    params_seq = list(params_seq)
    label = "|".join(dict.fromkeys(p.field for p in params_seq))
    params_seq = [p.replace(field=label) for p in params_seq]
    return jax.tree.map(lambda *xs: jnp.stack([jnp.asarray(x) for x in xs]), *params_seq)


# -- skeleton dynamics (eq. 8) ----------------------------------------------------------------
def inertia_terms(p: ArmParams) -> tuple[Any, Any, Any]:
    """``a1 = I1 + I2 + m2 l1²``, ``a2 = m2 l1 s2``, ``a3 = I2`` (= 0.16, 0.048, 0.045)."""
    a1 = p.upper_arm_inertia + p.forearm_inertia + p.forearm_mass * p.upper_arm_length**2
    a2 = p.forearm_mass * p.upper_arm_length * p.forearm_com
    return a1, a2, p.forearm_inertia


def inertia_matrix(theta: jax.Array, p: ArmParams) -> jax.Array:
    """``M(θ) = [[a1 + 2 a2 cos θ2, a3 + a2 cos θ2], [a3 + a2 cos θ2, a3]]``."""
    a1, a2, a3 = inertia_terms(p)
    c2 = jnp.cos(theta[1])
    off = a3 + a2 * c2
    return jnp.stack([jnp.stack([a1 + 2.0 * a2 * c2, off]),
                      jnp.stack([off, jnp.full_like(c2, a3)])])


def coriolis(theta: jax.Array, theta_dot: jax.Array, p: ArmParams) -> jax.Array:
    """``C(θ, θ̇) = a2 sin θ2 [-θ̇2 (2 θ̇1 + θ̇2), θ̇1²]``."""
    _, a2, _ = inertia_terms(p)
    d1, d2 = theta_dot[0], theta_dot[1]
    return a2 * jnp.sin(theta[1]) * jnp.stack([-d2 * (2.0 * d1 + d2), d1**2])


def joint_acceleration(x: jax.Array, activation: jax.Array, p: ArmParams) -> jax.Array:
    """``θ̈ = M(θ)⁻¹ (τ - C - B θ̇)`` (eq. 8) with ``τ`` from the muscles (eqs. 9–14)."""
    theta, theta_dot = x[:2], x[2:]
    tau = joint_torque(activation, theta, theta_dot, p)
    rhs = tau - coriolis(theta, theta_dot, p) - p.friction @ theta_dot
    m = inertia_matrix(theta, p)
    det = m[0, 0] * m[1, 1] - m[0, 1] * m[1, 0]
    return jnp.stack([m[1, 1] * rhs[0] - m[0, 1] * rhs[1],
                      m[0, 0] * rhs[1] - m[1, 0] * rhs[0]]) / det


def apply_joint_limits(x: jax.Array, p: ArmParams) -> jax.Array:
    """Clamp the angles to ``[joint_low, joint_high]`` and zero the velocity components that
    point into a limit the angle sits on [spec §2.1, decision from MotorNet]."""
    theta = jnp.clip(x[:2], p.joint_low, p.joint_high)
    into = ((theta <= p.joint_low) & (x[2:] < 0.0)) | ((theta >= p.joint_high) & (x[2:] > 0.0))
    return jnp.concatenate([theta, jnp.where(into, 0.0, x[2:])])


def physics_step(x: jax.Array, activation: jax.Array, p: ArmParams) -> jax.Array:
    """One forward-Euler step of ``physics_dt`` on ``[θ, θ̇]``, then the joint limits."""
    x_dot = jnp.concatenate([x[2:], joint_acceleration(x, activation, p)])
    return apply_joint_limits(x + p.physics_dt * x_dot, p)


def arm_dynamics(x: jax.Array, activation: jax.Array, p: ArmParams) -> jax.Array:
    """One control period: ``frame_skip`` physics steps with the activation held.

    ``activation`` is used as given (clip actions to ``[0, 1]`` first). This ignores the
    optional activation filter; see :func:`arm_dynamics_filtered`.
    """
    for _ in range(p.frame_skip):
        x = physics_step(x, activation, p)
    return x


def arm_dynamics_filtered(
    x: jax.Array, activation: jax.Array, command: jax.Array, p: ArmParams
) -> tuple[jax.Array, jax.Array]:
    """One control period with the first-order activation filter: each physics step first
    moves the activation towards ``command``, then integrates the skeleton. Returns
    ``(x', activation')``."""
    for _ in range(p.frame_skip):
        activation = filter_activation(activation, command, p.physics_dt, p)
        x = physics_step(x, activation, p)
    return x, activation


# -- kinematics and obstacle distance (spec §2.3) ---------------------------------------------
def forward_kinematics(theta: jax.Array, p: ArmParams) -> jax.Array:
    """Shoulder ``V0``, elbow ``V1`` and hand ``V2`` positions in metres, shape ``(3, 2)``."""
    t1, t12 = theta[0], theta[0] + theta[1]
    elbow = p.upper_arm_length * jnp.stack([jnp.cos(t1), jnp.sin(t1)])
    hand = elbow + p.forearm_length * jnp.stack([jnp.cos(t12), jnp.sin(t12)])
    return jnp.stack([jnp.zeros_like(elbow), elbow, hand])


def hand_position(theta: jax.Array, p: ArmParams) -> jax.Array:
    """The hand (end point) ``V2``, shape ``(2,)``."""
    return forward_kinematics(theta, p)[2]


def segment_distance(point: jax.Array, start: jax.Array, end: jax.Array) -> jax.Array:
    """Distance from ``point`` to the segment ``[start, end]`` (projection clamped to it)."""
    seg = end - start
    frac = jnp.clip(jnp.dot(point - start, seg) / jnp.dot(seg, seg), 0.0, 1.0)
    return jnp.linalg.norm(point - (start + frac * seg))


def arm_obstacle_distance(theta: jax.Array, center: jax.Array, p: ArmParams) -> jax.Array:
    """Shortest distance from the obstacle centre to the arm: the minimum over the upper arm
    ``(V0, V1)`` and the forearm ``(V1, V2)`` (paper Fig. 6A)."""
    v = forward_kinematics(theta, p)
    return jnp.minimum(segment_distance(center, v[0], v[1]), segment_distance(center, v[1], v[2]))


# -- a scripted posture controller (for demos and tests, not part of the paper) -------------
@struct.dataclass
class PostureGains:
    """Gains of :func:`posture_action` [decision].

    Attributes:
        stiffness: joint-space proportional gain (N·m/rad).
        damping: joint-space derivative gain (N·m·s/rad).
        co_contraction: baseline activation of every muscle, so antagonists can both pull.
        force_floor: lower bound on ``f_l f_v`` when inverting the muscle force (avoids
            dividing by a vanishing force factor).
    """

    stiffness: float = 20.0
    damping: float = 3.0
    co_contraction: float = 0.1
    force_floor: float = 0.1


def posture_action(
    obs_or_x: jax.Array, target_angles: jax.Array, p: ArmParams,
    gains: PostureGains | None = None,
) -> jax.Array:
    """Muscle activations in ``[0, 1]`` that drive the arm towards ``target_angles`` (rad).

    A joint-space PD law ``τ* = K (θ* - θ) - D θ̇`` is turned into activations by inverting
    eq. 10 around a co-contraction baseline ``a0``: with ``f = force_scale · f_l f_v`` per muscle
    at the current state, ``a = clip(a0 + (L⁺ (τ* - L (f a0))) / f, 0, 1)``, ``L⁺`` the
    pseudo-inverse of the moment arms. Without clipping the muscles produce exactly ``τ*``.
    Accepts a state ``x`` or an observation whose first four entries are ``x``; ``gains``
    defaults to :class:`PostureGains` ``()``.
    """
    gains = PostureGains() if gains is None else gains
    theta, theta_dot = obs_or_x[:2], obs_or_x[2:4]
    tau_star = gains.stiffness * (target_angles - theta) - gains.damping * theta_dot
    length = muscle_length(theta, p)
    factor = force_length(length, p) * force_velocity(length, muscle_velocity(theta_dot, p), p)
    force = p.force_scale * jnp.maximum(factor, gains.force_floor)
    base = jnp.full_like(force, gains.co_contraction)
    residual = tau_star - p.moment_arms @ (force * base)
    pinv = p.moment_arms.T @ jnp.linalg.inv(p.moment_arms @ p.moment_arms.T)
    return jnp.clip(base + (pinv @ residual) / force, 0.0, 1.0)
