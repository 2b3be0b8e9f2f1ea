"""The arm tasks: ``hiddpg/ArmReach-v0`` and ``hiddpg/ArmObstacle-v0`` (spec §2.4, §3).

Both act on the six-muscle arm of :mod:`hiddpg.envs.arm`: the action is six activations in
``[0, 1]`` (clipped), held for one control period of ``dt = 0.02`` s (``frame_skip = 2`` physics
steps of 0.01 s). The reward is ``-|hand - hand_target|_2`` (metres) after the action. ArmObstacle
(the paper's Fig. 6 / Fig. 8 task) adds a disc the whole arm must avoid: touching it gives
``collision_reward`` and terminates the episode.

Also here: :class:`DetourScript` / :func:`detour_action`, the scripted two-stroke movement of the
paper's Fig. 6B (via ``(60°, 130°)`` to the target ``(90°, 60°)``), and :func:`scripted_rollout`.

[decision] marks a value of ours where the paper is silent; docs/environments.md (its tables of
constants, each tagged) lists them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

from hiddpg.envs.arm import (
    ArmParams,
    PostureGains,
    arm_dynamics,
    arm_dynamics_filtered,
    arm_obstacle_distance,
    build_params,
    hand_position,
    posture_action,
)
from hiddpg.envs.base import Environment, GoalSpace, StepResult, check_range


def _rad(*degrees: float) -> Any:
    """Dataclass default factory: a float array of angles given in degrees, stored in radians."""
    return struct.field(default_factory=lambda: jnp.radians(jnp.asarray(degrees, dtype=float)))


def _vec(*values: float) -> Any:
    return struct.field(default_factory=lambda: jnp.asarray(values, dtype=float))


@struct.dataclass
class ArmState:
    """Episode state: ``x = [θ1, θ2, θ̇1, θ̇2]``, ``t`` actions taken, the joint-space ``target``
    (rad) and the muscle ``activation`` (the filter state; the last clipped action when the
    activation filter is off)."""

    x: jax.Array
    t: jax.Array
    target: jax.Array
    activation: jax.Array


@struct.dataclass
class ArmReachParams(ArmParams):
    """ArmReach params: the arm's (:class:`ArmParams`) plus, all angles in rad [decision]:

    start: start posture, ``(45°, 90°)``, zero velocity.
    target_low, target_high: the target box, ``θ1 ∈ [20°, 110°]``, ``θ2 ∈ [30°, 130°]``.
    success_radius: hand within this of the target counts as success in ``info`` (0.03 m).
    max_steps: horizon, 50 control steps (1 s), then truncated (static).
    """

    start: jax.Array = _rad(45.0, 90.0)
    target_low: jax.Array = _rad(20.0, 30.0)
    target_high: jax.Array = _rad(110.0, 130.0)
    success_radius: float = 0.03
    max_steps: int = struct.field(pytree_node=False, default=50)


@struct.dataclass
class ArmObstacleParams(ArmParams):
    """ArmObstacle params: the arm's (:class:`ArmParams`) plus [decision]:

    start: start posture ``(45°, 90°)`` in rad (hand ≈ ``(-0.021, 0.445)`` m).
    target: joint target ``(90°, 60°)`` in rad (hand ≈ ``(-0.286, 0.465)`` m).
    obstacle_center: ``(-0.15, 0.48)`` m.
    obstacle_diameter: collision when the arm is closer than this to the centre, 0.04 m.
    collision_reward: reward of the colliding step, -100 (worse than any non-colliding
        return, ``75 × 1.26``).
    success_radius: hand within 0.03 m of the target at the end, no collision = success.
    max_steps: horizon, 75 control steps (1.5 s), then truncated (static).
    """

    start: jax.Array = _rad(45.0, 90.0)
    target: jax.Array = _rad(90.0, 60.0)
    obstacle_center: jax.Array = _vec(-0.15, 0.48)
    obstacle_diameter: float = 0.04
    collision_reward: float = -100.0
    success_radius: float = 0.03
    max_steps: int = struct.field(pytree_node=False, default=75)


def _check_posture(name: str, angles: jax.Array, p: ArmParams) -> None:
    if not bool(jnp.all((angles >= p.joint_low) & (angles <= p.joint_high))):
        raise ValueError(
            f"{name}={angles} (rad) is outside the joint limits [{p.joint_low}, {p.joint_high}]"
        )


class _ArmTask(Environment):
    """What the two arm tasks share: sizes, action box, dynamics, goal space, validation."""

    state_dim = 4
    action_dim = 6
    action_low = 0.0
    action_high = 1.0
    dt = 0.02
    goal_space = GoalSpace(indices=(0, 1), low=(0.0, 0.0),
                           high=(math.radians(140.0), math.radians(160.0)))
    params_class: type = ArmParams

    def default_params(self, **overrides: Any) -> Any:
        p = build_params(self.params_class(), overrides)
        if not math.isclose(float(p.physics_dt) * p.frame_skip, self.dt, rel_tol=1e-6):
            raise ValueError(
                f"physics_dt={p.physics_dt} times frame_skip={p.frame_skip} must equal the "
                f"control period dt={self.dt} of {self.name}"
            )
        if not isinstance(p.max_steps, int) or p.max_steps < 1:
            raise ValueError(f"max_steps={p.max_steps!r} must be an int >= 1")
        check_range("success_radius", p.success_radius, 0.0, strict_low=True)
        _check_posture("start", p.start, p)
        return p

    def dynamics(self, x: jax.Array, action: jax.Array, params: Any) -> jax.Array:
        """One control period of the arm (eq. 8–14) on ``x``; the activation filter, if
        switched on, is bypassed (the action is the activation)."""
        return arm_dynamics(x, self.clip_action(action), params)

    def _start(self, params: Any, target: jax.Array) -> ArmState:
        x = jnp.concatenate([params.start, jnp.zeros_like(params.start)])
        return ArmState(x=x, t=jnp.zeros((), jnp.int32), target=jnp.asarray(target, x.dtype),
                        activation=jnp.zeros((self.action_dim,), x.dtype))

    def _advance(self, state: ArmState, action: jax.Array, params: Any) -> ArmState:
        command = self.clip_action(action)
        if params.activation_filter:
            x, activation = arm_dynamics_filtered(state.x, state.activation, command, params)
        else:
            x, activation = arm_dynamics(state.x, command, params), command
        return state.replace(x=x, t=state.t + 1, activation=activation)

    def _reach_info(self, state: ArmState, params: Any) -> dict[str, jax.Array]:
        hand = hand_position(state.x[:2], params)
        distance = jnp.linalg.norm(hand - hand_position(state.target, params))
        return {"hand": hand, "distance": distance}


class ArmReach(_ArmTask):
    """Reach a random joint-space target in 1 s; observation ``[θ1, θ2, θ̇1, θ̇2, θ1*, θ2*]``."""

    name = "ArmReach"
    obs_dim = 6
    params_class = ArmReachParams

    def default_params(self, **overrides: Any) -> ArmReachParams:
        """Spec defaults with ``overrides`` (field names of :class:`ArmReachParams`)."""
        p = super().default_params(**overrides)
        if not bool(jnp.all(p.target_low < p.target_high)):
            raise ValueError(f"target_low={p.target_low} must be below target_high={p.target_high}")
        _check_posture("target_low", p.target_low, p)
        _check_posture("target_high", p.target_high, p)
        return p

    def reset(self, key: jax.Array, params: ArmReachParams,
              options: Any = None) -> tuple[jax.Array, ArmState]:
        """Draw the target uniformly from ``[target_low, target_high]``;
        ``options={"target": (θ1*, θ2*)}`` (rad) fixes it instead (also under ``jit``: the
        dict's keys are static, the target may be traced)."""
        if options is not None and options.get("target") is not None:
            return self.reset_to(key, params, jnp.asarray(options["target"]))
        target = jax.random.uniform(key, (2,), minval=params.target_low,
                                    maxval=params.target_high)
        return self.reset_to(key, params, target)

    def reset_to(self, key: jax.Array, params: ArmReachParams,
                 target: jax.Array) -> tuple[jax.Array, ArmState]:
        """Start an episode with the given joint-space ``target`` (rad); pure and jittable.
        ``key`` is unused (kept for a uniform signature)."""
        del key
        state = self._start(params, target)
        return self.observe(state), state

    def observe(self, state: ArmState) -> jax.Array:
        return jnp.concatenate([state.x, state.target])

    def step(self, key: jax.Array, state: ArmState, action: jax.Array,
             params: ArmReachParams) -> StepResult:
        del key
        state = self._advance(state, action, params)
        info = self._reach_info(state, params)
        info["success"] = info["distance"] < params.success_radius
        return StepResult(self.observe(state), state, -info["distance"], jnp.asarray(False),
                          state.t >= params.max_steps, info)


class ArmObstacle(_ArmTask):
    """Reach ``(90°, 60°)`` in 1.5 s without the arm touching the obstacle (paper Fig. 6);
    observation ``[θ1, θ2, θ̇1, θ̇2]``."""

    name = "ArmObstacle"
    obs_dim = 4
    params_class = ArmObstacleParams

    def default_params(self, **overrides: Any) -> ArmObstacleParams:
        """Spec defaults with ``overrides`` (field names of :class:`ArmObstacleParams`)."""
        p = super().default_params(**overrides)
        _check_posture("target", p.target, p)
        check_range("obstacle_diameter", p.obstacle_diameter, 0.0, strict_low=True)
        check_range("collision_reward", p.collision_reward)
        if float(arm_obstacle_distance(p.start, p.obstacle_center, p)) < p.obstacle_diameter:
            raise ValueError(f"start={p.start} collides with the obstacle at "
                             f"obstacle_center={p.obstacle_center}")
        return p

    def reset(self, key: jax.Array, params: ArmObstacleParams,
              options: Any = None) -> tuple[jax.Array, ArmState]:
        """The fixed start posture; ``key`` and ``options`` are unused."""
        del key, options
        state = self._start(params, params.target)
        return state.x, state

    def step(self, key: jax.Array, state: ArmState, action: jax.Array,
             params: ArmObstacleParams) -> StepResult:
        """Collision is checked on the state after the control period."""
        del key
        state = self._advance(state, action, params)
        info = self._reach_info(state, params)
        clearance = arm_obstacle_distance(state.x[:2], params.obstacle_center, params)
        collision = clearance < params.obstacle_diameter
        info.update(obstacle_distance=clearance, collision=collision,
                    success=(info["distance"] < params.success_radius) & ~collision)
        reward = jnp.where(collision, params.collision_reward, -info["distance"])
        truncated = (state.t >= params.max_steps) & ~collision
        return StepResult(state.x, state, reward, collision, truncated, info)


# -- scripted movements (demos, tests) --------------------------------------------------------
@struct.dataclass
class DetourScript:
    """The two-stroke detour of Fig. 6B [decision]: the posture controller first aims at
    ``via`` (rad, default ``(60°, 130°)``, away from the obstacle), then, from action number
    ``switch_step`` on (default 20, i.e. 0.4 s), at the task's target."""

    via: jax.Array = _rad(60.0, 130.0)
    switch_step: int = 20
    gains: PostureGains = PostureGains()


def detour_action(state: ArmState, params: ArmObstacleParams,
                  script: DetourScript | None = None) -> jax.Array:
    """Activations of the scripted detour at ``state`` (pure, jittable); ``script``
    defaults to :class:`DetourScript` ``()``."""
    script = DetourScript() if script is None else script
    goal = jnp.where(state.t < script.switch_step, script.via, state.target)
    return posture_action(state.x, goal, params, script.gains)


def scripted_rollout(
    env: Environment, params: Any, policy: Callable[[Any, Any], jax.Array],
    key: jax.Array, options: Any = None,
) -> tuple[ArmState, StepResult]:
    """Run ``policy(state, params) -> action`` for ``max_steps`` steps with ``lax.scan``.

    Returns ``(start_state, steps)`` with every field of ``steps`` stacked over time; steps after
    a termination keep being simulated, mask them with the ``terminated`` flags. ``options`` is
    passed to ``reset`` (so do not ``jit`` this when it is given).
    """
    reset_key, step_key = jax.random.split(key)
    _, state0 = env.reset(reset_key, params, options)

    def body(state: Any, k: jax.Array) -> tuple[Any, StepResult]:
        result = env.step(k, state, policy(state, params), params)
        return result.state, result

    keys = jax.random.split(step_key, env.max_steps(params))
    return state0, jax.lax.scan(body, state0, keys)[1]
