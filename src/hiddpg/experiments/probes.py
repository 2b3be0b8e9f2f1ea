"""The high level's critic against the truth: what it believes a first segment is worth, and
what doing that segment actually returns.

:func:`first_segment` takes a trained HI-DDPG run's state and, for each seed, the noise-free
first high-level action ``(g, T)`` at the start state; then, for each duration ``T'`` asked
for, it compares the critic's ``Q_H(s_0, (g, T'))`` with the truth: the high-level return
``f`` (environment reward minus the switch costs) of holding ``g`` for ``T'`` steps and then
following the learned high level, with the run's own low level, noise-free — the evaluation
episode with its first duration replaced. docs/results.md uses it to show that the duration
critic is wrong where its actor does not go (``scripts/first_segment.py`` prints the table).
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from hiddpg.agents.hi_ddpg import HIDDPG


def _episode(agent: HIDDPG, params: Any, high: Any, low: Any, key: jax.Array,
             first: jax.Array) -> dict[str, jax.Array]:
    """The evaluation episode of :meth:`HIDDPG.evaluate` (same keys) with the first
    high-level action replaced by ``first`` (a unit action)."""
    env, c = agent.env, agent.config
    horizon = env.max_steps(params)
    k_reset, k_steps = jax.random.split(key)
    obs, env_state = env.reset(k_reset, params)

    def step(carry, inp):
        obs, env_state, alive, action, remaining, ret, env_ret, goals = carry
        t, k = inp
        switch = alive & (remaining <= 0)
        own = agent.high.act(high, obs, jnp.zeros((0,)))
        action = jnp.where(switch, jnp.where(t == 0, first, own), action)
        goal, duration = agent.decode(action)
        n = jnp.clip(jnp.round(duration), 1, horizon - t).astype(jnp.int32)
        remaining = jnp.where(switch, n, remaining) - 1
        goals = goals + switch.astype(jnp.int32)
        unit = agent.low.act(low, obs, goal)
        res = env.step(jax.random.split(k, 7)[4], env_state, agent.env_action(unit), params)
        r = jnp.where(alive, res.reward, 0.0)
        cost = jnp.where(switch & (goals > 1), c.switch_cost, 0.0)
        env_state = jax.tree.map(lambda a, b: jnp.where(alive, a, b), res.state, env_state)
        obs = jnp.where(alive, res.obs, obs)
        alive = alive & ~(res.terminated | res.truncated)
        return (obs, env_state, alive, action, remaining, ret + r - cost, env_ret + r,
                goals), None

    zero = jnp.zeros(())
    carry = (obs, env_state, jnp.array(True), first, jnp.zeros((), jnp.int32), zero, zero,
             jnp.zeros((), jnp.int32))
    inputs = (jnp.arange(horizon), jax.random.split(k_steps, horizon))
    (_, _, alive, _, _, ret, env_ret, goals), _ = jax.lax.scan(step, carry, inputs)
    return {"return": ret, "env_return": env_ret, "goals": goals, "completed": alive}


def first_segment(trainer: Any, state: Any, keys: jax.Array, durations: Any,
                  goal: Any = None) -> dict[str, np.ndarray]:
    """Per seed (axis 0) and duration (axis 1): the critic's ``q`` and the true ``return``
    (also ``env_return`` and ``goals``, the number of goals used) of the first segment
    ``(g, T)``, ``g`` the actor's first goal (or ``goal``, in the goal space's units) and
    ``T`` each of ``durations``; ``policy`` holds each seed's own first action decoded
    (``goal``, ``duration``) with its critic value and return. ``keys`` are the evaluation keys
    (:func:`hiddpg.commands.eval.eval_keys`), so that the actor's own ``T`` reproduces the
    evaluation's return."""
    agent, params = trainer.agent, trainer.env_params
    if not isinstance(agent, HIDDPG):
        raise ValueError(f"first_segment probes HI-DDPG runs, not {type(agent).__name__}")
    c, space = agent.config, agent.env.goal_space
    durations = jnp.asarray(durations, jnp.float32)
    if bool(jnp.any((durations < c.duration_min) | (durations > c.duration_max))):
        raise ValueError(f"durations {np.asarray(durations).tolist()} must lie in "
                         f"[duration_min, duration_max] = [{c.duration_min}, {c.duration_max}]")
    t_units = 2.0 * (durations - c.duration_min) / (c.duration_max - c.duration_min) - 1.0
    fixed = None if goal is None else space.unscale(jnp.asarray(goal, jnp.float32))

    def one(agent_state, key):
        high, low = agent_state.high, agent_state.low
        obs, _ = agent.env.reset(jax.random.split(key)[0], params)
        own = agent.high.act(high, obs, jnp.zeros((0,)))
        base = own if fixed is None else own.at[: agent.goal_dim].set(fixed)
        actions = jnp.concatenate(
            [jnp.broadcast_to(base[: agent.goal_dim], (len(t_units), agent.goal_dim)),
             t_units[:, None]], axis=1)
        q = jax.vmap(lambda a: agent.high.block.q(high.block.critic, obs, a))
        probe = jax.vmap(lambda a: _episode(agent, params, high, low, key, a))
        mine = _episode(agent, params, high, low, key, own)
        g, duration = agent.decode(own)
        return {"q": q(actions), **probe(actions),
                "policy": {"goal": space.select(g), "duration": duration,
                           "q": q(own[None])[0], "return": mine["return"]}}

    out = jax.jit(jax.vmap(one))(state.agent, keys)
    return jax.tree.map(np.asarray, out)
