"""What HI-DDPG carries: between episodes (:class:`HIDDPGState`), within one
(:class:`Segment`: the current segment and both noise processes), the sums an episode reports,
and the random streams of one step."""

from __future__ import annotations

import jax
import jax.numpy as jnp
from flax import struct

from hiddpg.agents import noise
from hiddpg.agents.episode import EpisodeMetrics
from hiddpg.agents.level import LevelState
from hiddpg.agents.streams import split_named
from hiddpg.configs import NoiseConfig

#: per level, means over the episode's updates: the losses, the critic's mean value of its
#: batch and the mean norm of the actor's action gradient (model term included)
_LOSSES = ("critic_loss", "actor_loss", "model_loss", "q_mean", "dq_da_norm")

#: the random streams of one step, one per purpose
STREAMS = ("high_noise", "high_random", "choice_explore", "choice_settle", "low_noise",
           "low_random", "env", "low_update", "high_update", "high_hindsight")


@struct.dataclass
class HIDDPGState:
    """Both levels (networks, models, buffers) and the run's counters."""

    high: LevelState
    low: LevelState
    env_steps: jax.Array
    episodes: jax.Array


@struct.dataclass
class Segment:
    """The hierarchy's state within an episode: the current segment and both noises."""

    high_action: jax.Array  # unit box: goal entries then T
    goal: jax.Array  # full goal vector (obs shape)
    remaining: jax.Array  # low-level steps left in the segment
    seg_obs: jax.Array  # s_{t_i}, the high level's input
    seg_reward: jax.Array  # Σ r_env so far in the segment
    n_goals: jax.Array
    t: jax.Array  # steps taken in the episode
    discount: jax.Array  # γ_H to the number of segments ended so far
    high_noise: noise.NoiseState
    low_noise: noise.NoiseState


def new_segment(obs: jax.Array, seg_obs: jax.Array, goal_dim: int, action_dim: int,
                high_noise: NoiseConfig, low_noise: NoiseConfig) -> Segment:
    """An episode's start: no goal yet (a switch at the first step), fresh OU processes."""
    return Segment(
        high_action=jnp.zeros((goal_dim + 1,)), goal=jnp.zeros_like(obs),
        remaining=jnp.zeros((), jnp.int32), seg_obs=seg_obs, seg_reward=jnp.zeros(()),
        n_goals=jnp.zeros((), jnp.int32), t=jnp.zeros((), jnp.int32), discount=jnp.ones(()),
        high_noise=noise.init(high_noise, goal_dim + 1),
        low_noise=noise.init(low_noise, action_dim))


def zero_sums() -> dict[str, jax.Array]:
    """The per-step sums of an episode: both levels' losses and updates, the returns."""
    names = [f"{lv}_{m}" for lv in ("high", "low") for m in _LOSSES]
    names += ["high_updates", "low_updates", "env_return", "ret", "length", "reach_error",
              "segments", "high_q_start", "high_return_discounted"]
    return {n: jnp.zeros(()) for n in names}


def update_sums(high_m: dict, low_m: dict, learn_high: jax.Array,
                learn_low: jax.Array) -> dict[str, jax.Array]:
    """One step's additions to the loss and update sums."""
    adds = {f"low_{m}": low_m[m] for m in _LOSSES}
    adds.update({f"high_{m}": high_m[m] for m in _LOSSES})
    adds.update(low_updates=learn_low, high_updates=learn_high)
    return adds


def episode_metrics(state: HIDDPGState, seg: Segment, sums: dict,
                    train: bool) -> EpisodeMetrics:
    """The episode's returns, length, switches (goals after the first) and ``reach_error``,
    the mean distance between a segment's last state and its goal (goal entries); the high
    critic's value of the episode's first choice (``high_q_start``) against what that value
    estimates, the high level's discounted return ``Σ_k γ_H^k f_k`` over the episode's
    segments (``high_return_discounted``: in a noise-free evaluation the two differ by the
    critic's error at the start state); in training also each level's mean losses, critic
    value and action-gradient norm per update."""
    s = sums
    extra = {"env_steps": state.env_steps.astype(jnp.float32),
             "reach_error": s["reach_error"] / jnp.maximum(s["segments"], 1.0),
             "high_q_start": s["high_q_start"],
             "high_return_discounted": s["high_return_discounted"]}
    if train:
        for lv in ("high", "low"):
            n = jnp.maximum(s[f"{lv}_updates"], 1.0)
            extra.update({f"{lv}_{m}": s[f"{lv}_{m}"] / n for m in _LOSSES})
    switches = jnp.maximum(seg.n_goals - 1, 0).astype(jnp.float32)
    return EpisodeMetrics(s["ret"], s["env_return"], s["length"], switches, extra)


def step_keys(key: jax.Array) -> dict[str, jax.Array]:
    """One step's random streams by name (:data:`STREAMS`)."""
    return split_named(key, STREAMS)
