"""The line a finished run ends with: its final evaluation on a scale (:func:`result_line`).

The three numbers are one quantity, the environment's return of an evaluation episode (the
``eval_env_return`` column of metrics.csv; HI-DDPG's own return adds switch costs and is not
comparable with the others)::

    final evaluation: environment return -5.02 (seed 0); reference plan 0.00, random policy
    -64.7 | wall 63.2 s | run runs/x

* the trained policy's: the last evaluation of each seed, as mean ± sample std over seeds;
* the reference plan's (:func:`reference_return`): on the puck trajectory tasks, the reference
  controller driving the reference goals, which draws the reference trajectory itself;
  omitted on tasks without a reference plan;
* a uniformly random policy's (:func:`random_policy_return`): the mean over
  :data:`RANDOM_EPISODES` episodes keyed ``split(PRNGKey(RANDOM_KEY), RANDOM_EPISODES)``. One
  random episode per seed would be no scale, since a random episode's return scatters widely;
  the mean over many episodes is a steady one.

Both baselines are computed on the run's task with its env overrides, each as one jitted
rollout compiled once per task and overrides in this process.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from hiddpg.configs import TrainConfig
from hiddpg.envs import make
from hiddpg.envs.puckworld import PuckTrajectory, reference_action, reference_goal
from hiddpg.plan import plural
from hiddpg.runs import Run

#: The random policy's mean is over this many episodes, keyed
#: ``split(PRNGKey(RANDOM_KEY), RANDOM_EPISODES)`` (one vmapped rollout, cheap next to training).
RANDOM_KEY = 0
RANDOM_EPISODES = 1000
#: The metrics.csv column of the evaluation's environment return.
ENV_RETURN_COLUMN = "eval_env_return"

#: A policy: ``(key, env state, params) -> normalised action``.
Policy = Callable[[jax.Array, Any, Any], jax.Array]
_ROLLOUTS: dict[tuple, Callable[[jax.Array], np.ndarray]] = {}


def episode_return(core: Any, policy: Policy) -> Callable[[jax.Array, Any], jax.Array]:
    """``(key, params) -> environment return`` of one episode of ``policy`` (pure).

    ``reset_key, run_key = split(key)``; step ``t`` splits ``split(run_key, horizon)[t]`` into
    the policy's key and the env's; rewards count up to and including the step that
    terminates or truncates the episode.
    """

    def episode(key: jax.Array, params: Any) -> jax.Array:
        reset_key, run_key = jax.random.split(key)
        _, state = core.reset(reset_key, params)

        def body(carry, step_key):
            state, alive, total = carry
            act_key, env_key = jax.random.split(step_key)
            res = core.step(env_key, state, policy(act_key, state, params), params)
            total = total + jnp.where(alive, res.reward, 0.0)
            alive = alive & ~(jnp.asarray(res.terminated) | jnp.asarray(res.truncated))
            return (res.state, alive, total), None

        carry = (state, jnp.ones((), bool), jnp.zeros((), jnp.float32))
        steps = jax.random.split(run_key, core.max_steps(params))
        (_, _, total), _ = jax.lax.scan(body, carry, steps)
        return total

    return episode


def _returns(config: TrainConfig, kind: str, make_policy: Callable[[Any], Policy]
             ) -> Callable[[jax.Array], np.ndarray]:
    """``keys -> returns`` of the policy ``make_policy(core)`` on ``config``'s task and env
    overrides, jitted; kept per (task, overrides, ``kind``) when the overrides hash."""
    cache_key: tuple | None = (config.task, config.env, kind)
    try:
        hash(cache_key)
    except TypeError:
        cache_key = None
    if cache_key is not None and cache_key in _ROLLOUTS:
        return _ROLLOUTS[cache_key]
    core, params = make(config.task, **config.env_overrides)
    run = jax.jit(jax.vmap(episode_return(core, make_policy(core)), in_axes=(0, None)))

    def returns(keys: jax.Array) -> np.ndarray:
        return np.asarray(run(jnp.asarray(keys), params), np.float64)

    if cache_key is not None:
        _ROLLOUTS[cache_key] = returns
    return returns


def uniform_policy(core: Any) -> Policy:
    """Actions drawn uniformly from the action box ``[action_low, action_high]`` every step."""

    def act(key: jax.Array, state: Any, params: Any) -> jax.Array:
        return jax.random.uniform(key, (core.action_dim,), jnp.float32,
                                  core.action_low, core.action_high)

    return act


def reference_policy(core: Any) -> Policy:
    """The puck's reference (LQR) controller aiming at the reference goal of each step."""

    def act(key: jax.Array, state: Any, params: Any) -> jax.Array:
        goal = reference_goal(state.t, params.goals, params.switch_steps)
        return reference_action(state.x, goal, params)

    return act


def random_keys(n: int = RANDOM_EPISODES) -> jax.Array:
    """The keys of the random policy's episodes in :func:`result_line`."""
    return jax.random.split(jax.random.PRNGKey(RANDOM_KEY), n)


def random_policy_return(config: TrainConfig, keys: jax.Array) -> np.ndarray:
    """The environment return of a uniformly random policy, one episode per key, on
    ``config``'s task with its env overrides (see :func:`episode_return` for the keys)."""
    return _returns(config, "random", uniform_policy)(keys)


def reference_return(config: TrainConfig) -> float | None:
    """The environment return of the task's reference plan (the puck trajectory tasks: the
    reference controller through the reference goals); ``None`` for a task without one."""
    core, _ = make(config.task, **config.env_overrides)
    if not isinstance(core, PuckTrajectory):
        return None
    keys = jax.random.PRNGKey(0)[None]  # the reset and the controller use no randomness
    return float(_returns(config, "reference", reference_policy)(keys)[0])


def final_evaluation(run: Run) -> tuple[dict[int, float], bool]:
    """Each seed's last evaluation return in metrics.csv and whether it is the environment's
    return (``eval_env_return``; else the agent's ``eval_return`` of an older run)."""
    rows = run.read_metrics()
    env = bool(rows) and ENV_RETURN_COLUMN in rows[0]
    column = ENV_RETURN_COLUMN if env else "eval_return"
    out: dict[int, float] = {}
    for row in rows:
        if row.get(column):
            out[int(row["seed"])] = float(row[column])
    return out, env


def number(x: float) -> str:
    """Three significant digits at most for |x| < 1000 (``-5.02``, ``-41.3``, ``0.00``),
    none after the point beyond; no sign on a number that rounds to zero."""
    size = abs(x)
    text = f"{x:.2f}" if size < 10 else f"{x:.1f}" if size < 100 else f"{x:.0f}"
    return text[1:] if text.startswith("-") and not text.strip("-0.") else text


def score_text(finals: dict[int, float], label: str) -> str:
    """``label M (seed S)`` for one seed, ``label M ± D (mean ± std over N seeds)`` for
    several (D: sample std)."""
    values = np.array(list(finals.values()), np.float64)
    if values.size == 1:
        return f"{label} {number(values[0])} (seed {next(iter(finals))})"
    return (f"{label} {number(values.mean())} ± {number(values.std(ddof=1))} "
            f"(mean ± std over {plural(values.size, 'seed')})")


def result_line(run: Run, wall: float) -> str:
    """``final evaluation: environment return M ± D (mean ± std over N seeds); reference plan
    R, random policy Q | wall T s | run DIR`` (the reference plan only where the task has one;
    both baselines only when the environment's return was recorded)."""
    finals, env = final_evaluation(run)
    tail = f" | wall {wall:.1f} s | run {run.path}"
    if not finals:
        return "no evaluation recorded" + tail
    if not env:
        return "final evaluation: " + score_text(finals, "return") + tail
    baselines = []
    reference = reference_return(run.config)
    if reference is not None:
        baselines.append(f"reference plan {number(reference)}")
    random = random_policy_return(run.config, random_keys())
    baselines.append(f"random policy {number(float(random.mean()))}")
    return ("final evaluation: " + score_text(finals, "environment return") + "; "
            + ", ".join(baselines) + tail)
