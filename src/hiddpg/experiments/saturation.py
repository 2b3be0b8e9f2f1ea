"""Whether a trained HI-DDPG run's low level still listens to its goals.

:func:`low_saturation` takes, for each seed, states and goals the low level met in training
(evenly spaced entries of its replay buffer ``D_L``) and its noise-free unit action
``μ_L([s, g])`` there: the share of action entries within ``margin`` of a bound (±1), the
mean ``|μ_L|``, the mean change ``|μ_L([s, g]) − μ_L([s, g'])|`` when each goal is replaced by
another stored goal (the goal's effect), and the action's spread over the states. A ``tanh``
actor driven into its bounds outputs ±1 at every state and for every goal: share 1, goal
effect 0, spread 0, and the arm moves the same way whatever the high level chooses
(``scripts/low_saturation.py`` prints and records it).
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from hiddpg.agents.hi_ddpg import HIDDPG


def low_saturation(trainer: Any, state: Any, samples: int = 2000, margin: float = 0.01,
                   shuffle_seed: int = 0) -> dict[str, np.ndarray]:
    """Per seed (axis 0): ``bound_share``, ``mean_abs``, ``goal_effect``, ``spread`` (the
    mean over action entries of the standard deviation over states) and ``stored`` (the
    transitions in ``D_L``), from ``samples`` evenly spaced stored transitions."""
    agent = trainer.agent
    if not isinstance(agent, HIDDPG):
        raise ValueError(f"low_saturation probes HI-DDPG runs, not {type(agent).__name__}")
    if samples < 2:
        raise ValueError(f"samples must be at least 2, not {samples}")
    low = state.agent.low
    rows = []
    for i in range(int(np.asarray(low.buffer.size).shape[0])):
        level = jax.tree.map(lambda x, i=i: x[i], low)
        stored = int(level.buffer.size)
        if stored < 2:
            raise ValueError(f"seed index {i}: the low level's buffer holds {stored} "
                             "transitions; the probe needs a trained run")
        idx = np.linspace(0, stored - 1, samples).astype(int)
        obs, goals = level.buffer.data.obs[idx], level.buffer.data.context[idx]
        other = goals[np.random.default_rng(shuffle_seed).permutation(samples)]
        act = jax.vmap(lambda s, g, level=level: agent.low.act(level, s, g))
        a, a_other = act(obs, goals), act(obs, other)
        rows.append({"bound_share": jnp.mean(jnp.abs(a) >= 1.0 - margin),
                     "mean_abs": jnp.mean(jnp.abs(a)),
                     "goal_effect": jnp.mean(jnp.abs(a - a_other)),
                     "spread": jnp.mean(jnp.std(a, axis=0)), "stored": stored})
    return {k: np.asarray([float(r[k]) for r in rows]) for k in rows[0]}


def saturation_table(record: dict[str, Any]) -> str:
    """A record of ``scripts/low_saturation.py`` as a markdown table, one row per run and
    seed."""
    lines = ["| run | episodes | seed | stored | bound_share | mean_abs | goal_effect | spread |",
             "|---|---|---|---|---|---|---|---|"]
    for run in record["runs"]:
        for seed, v in run["seeds"].items():
            lines.append(f"| {run['run']} | {run['episodes']} | {seed} | {int(v['stored'])} "
                         f"| {v['bound_share']:.3f} | {v['mean_abs']:.3f} "
                         f"| {v['goal_effect']:.4f} | {v['spread']:.4f} |")
    return "\n".join(lines)
