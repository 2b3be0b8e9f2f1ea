"""The high level's critic against the truth: what it believes a first segment is worth, and
what doing that segment actually returns.

:func:`first_segment` takes a trained HI-DDPG run's state and, for each seed, the noise-free
first high-level action ``(g, T)`` at the start state; then, for each duration ``T'`` asked
for, it compares the critic's ``Q_H(s_0, (g, T'))`` with the truth: the high-level return
``f`` (environment reward minus the switch costs) of holding ``g`` for ``T'`` steps and then
following the learned high level, with the run's own low level, noise-free — the evaluation
episode (:meth:`HIDDPG.evaluate`) with its first action replaced
(:class:`~hiddpg.experiments.overrides.FirstAction`). It shows whether the duration critic
is right for the durations its actor does not choose, where its policy gradient has no data
(``scripts/first_segment.py`` prints the table).
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from hiddpg.agents.hi_ddpg import HIDDPG
from hiddpg.experiments.overrides import with_first_action


def first_segment(trainer: Any, state: Any, keys: jax.Array, durations: Any,
                  goal: Any = None) -> dict[str, np.ndarray]:
    """Per seed (axis 0) and duration (axis 1): the critic's ``q`` and the true ``return``
    (also ``env_return``, ``goals``, the number of goals used, and ``first_goal``, the goal
    held first) of the first segment ``(g, T)``, ``g`` the actor's first goal (or ``goal``, in
    the goal space's units) and ``T`` each of ``durations``; ``policy`` holds each seed's own
    first action decoded (``goal``, ``duration``; with the hold choice the duration the choice
    makes) with its critic value and return. ``keys``
    are the evaluation keys (:func:`hiddpg.train.eval_keys`), so that the actor's own
    action reproduces the evaluation's return."""
    agent, params = trainer.agent, trainer.env_params
    if not isinstance(agent, HIDDPG):
        raise ValueError(f"first_segment probes HI-DDPG runs, not {type(agent).__name__}")
    c, space = agent.config, agent.env.goal_space
    durations = jnp.asarray(durations, jnp.float32)
    if bool(jnp.any((durations < c.duration_min) | (durations > c.duration_max))):
        raise ValueError(f"durations {np.asarray(durations).tolist()} must lie in "
                         f"[duration_min, duration_max] = [{c.duration_min}, {c.duration_max}]")
    t_units = agent.choice.duration_unit(durations)
    horizon = agent.env.max_steps(params)
    fixed = None if goal is None else space.unscale(jnp.asarray(goal, jnp.float32))

    def one(agent_state, key):
        obs, _ = agent.env.reset(jax.random.split(key)[0], params)  # evaluate's start state
        obs = agent.choice.inputs(obs, jnp.asarray(horizon), horizon)  # the high level's input
        own = agent.choice.policy(agent_state.high, obs, jnp.asarray(horizon))
        base = own if fixed is None else own.at[: agent.goal_dim].set(fixed)
        actions = jnp.concatenate(
            [jnp.broadcast_to(base[: agent.goal_dim], (len(t_units), agent.goal_dim)),
             t_units[:, None]], axis=1)
        q = jax.vmap(lambda a: agent.choice.q(agent_state.high, obs, a))

        def truth(first):
            probe = with_first_action(agent, first)
            metrics, traj = probe.evaluate(key, agent_state, params)
            return {"return": metrics["return"], "env_return": metrics["env_return"],
                    "goals": metrics["switches"].astype(jnp.int32) + 1,
                    "first_goal": traj["goal"][0]}

        g, duration = agent.decode(own)
        return {"q": q(actions), **jax.vmap(truth)(actions),
                "policy": {"goal": space.select(g), "duration": duration,
                           "q": q(own[None])[0], "return": truth(own)["return"]}}

    out = jax.jit(jax.vmap(one))(state.agent, keys)
    return jax.tree.map(np.asarray, out)


def end_value(trainer: Any, state: Any, keys: jax.Array) -> dict[str, np.ndarray]:
    """Per seed, what the high critic believes the noise-free evaluation episode is worth at
    its two ends: ``q_start``, ``Q_H(s_0, μ_H(s_0))`` (the evaluation's ``high_q_start``), and
    ``q_end``, ``Q_H(s_T, μ_H(s_T))`` at the state the episode ends in, the value a
    time-limit bootstrap adds to the last segment's target (spec §3; none where
    ``end_is_terminal``). Also ``steps``, ``ended_early`` (terminated before the horizon),
    ``goals`` (the goals the episode used), ``env_return`` and ``last_reward``. On the arm a
    ``q_end`` near the collision's cost at an end without a collision shows a critic that
    values going on past the time limit as worse than a collision."""
    agent, params = trainer.agent, trainer.env_params
    if not isinstance(agent, HIDDPG):
        raise ValueError(f"end_value probes HI-DDPG runs, not {type(agent).__name__}")
    horizon = agent.env.max_steps(params)

    def one(agent_state, key):
        metrics, traj = agent.evaluate(key, agent_state, params)
        steps = traj["alive"].sum().astype(jnp.int32)
        last = jnp.maximum(steps - 1, 0)
        left = jnp.asarray(horizon) - steps

        def value(obs, steps_left):
            hobs = agent.choice.inputs(obs, steps_left, horizon)
            action = agent.choice.policy(agent_state.high, hobs, steps_left)
            return agent.choice.q(agent_state.high, hobs, action)

        return {"q_start": value(traj["obs"][0], jnp.asarray(horizon)),
                "q_end": value(traj["next_obs"][last], left), "steps": steps,
                "ended_early": steps < horizon, "env_return": metrics["env_return"],
                "last_reward": traj["reward"][last],
                "goals": metrics["switches"].astype(jnp.int32) + 1}

    out = jax.jit(jax.vmap(one))(state.agent, keys)
    return jax.tree.map(np.asarray, out)


def add_end_values(record: dict[str, Any], entry: dict[str, Any]) -> dict[str, Any]:
    """``record`` with ``entry`` (one run of ``scripts/end_value.py``) added, replacing the entry
    of the same label (``run``) and nothing else: run directories of different studies share
    their names (names do not hold the seeds), so the label is what tells runs apart, as in
    :mod:`hiddpg.experiments.diagnosis`'s records."""
    runs = [r for r in record.get("runs", []) if r["run"] != entry["run"]]
    return {**record, "runs": runs + [entry]}


def end_value_table(record: dict[str, Any]) -> str:
    """A record of ``scripts/end_value.py`` as a markdown table, one row per run and seed."""
    lines = ["| run | episodes | seed | steps | goals | env_return | last_reward | q_start "
             "| q_end |", "|---|---|---|---|---|---|---|---|---|"]
    for run in record["runs"]:
        for seed, v in run["seeds"].items():
            steps = f"{v['steps']}" + (" (terminated)" if v["ended_early"] else "")
            lines.append(f"| {run['run']} | {run['episodes']} | {seed} | {steps} "
                         f"| {v['goals']} "
                         f"| {v['env_return']:.1f} | {v['last_reward']:.3f} "
                         f"| {v['q_start']:.1f} | {v['q_end']:.1f} |")
    return "\n".join(lines)
