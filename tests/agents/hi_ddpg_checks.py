"""Checks that rebuild a HI-DDPG episode from what the agent stored: a training episode from
the buffers ``D_L`` and ``D_H`` (segments, goals, durations, rewards, switch costs) and an
evaluation trajectory from its recorded steps, each against the environment recomputed from
the stored states and actions."""

from __future__ import annotations

import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from hi_ddpg_support import ReachState, Run

from hiddpg.agents.hi_ddpg import HIDDPG
from hiddpg.agents.transition import Transition
from hiddpg.envs.base import Environment


@functools.cache
def _env_step(env: Environment, state_cls: type):
    """``(params, x, t, a) -> (obs, reward, terminated)`` of the environment, over a batch."""

    @jax.jit
    def step(params, x, t, a):
        def one(x, t, a):
            res = env.step(jax.random.PRNGKey(0), state_cls(x=x, t=t), a, params)
            return res.obs, res.reward, res.terminated

        return jax.vmap(one)(x, t, a)

    return step


def _unit_to(lo, hi, u):
    """The affine map of the spec (as ``GoalSpace.scale`` and ``HIDDPG.decode``), in float32."""
    f32 = lambda x: np.asarray(x, np.float32)  # noqa: E731
    return f32(lo) + (f32(u) + np.float32(1.0)) * np.float32(0.5) * (f32(hi) - f32(lo))


class Episode(NamedTuple):
    s: np.ndarray
    goal: np.ndarray
    r_env: np.ndarray
    starts: list  # segment start steps
    stops: list  # segment end steps (exclusive)
    cut: bool  # the last segment was cut: round(T) > the steps left


def _rows(data: Transition, start: int, stop: int) -> dict[str, np.ndarray]:
    """Buffer slots ``start:stop`` as arrays named like Alg. 1's ``(s, c, a, r, s', term)``."""
    names = {"s": "obs", "c": "context", "a": "action", "r": "reward", "s2": "next_obs",
             "terminated": "terminated"}
    return {k: np.asarray(getattr(data, f)[start:stop]) for k, f in names.items()}


def check_episode(run: Run, e: int, length: int, state_cls: type = ReachState,
                  with_high: bool = True) -> Episode:
    """Check episode ``e`` (1-based) from the buffers: it must have ``length`` steps; D_L
    rewards are intrinsic; D_H has one entry per segment, its stored (g, T) fixes the goal and
    the length ``clip(round(T), 1, steps left)`` of each segment, its reward is the segment's
    environment reward minus the switch cost, and its states are the segment's ends."""
    agent, env, c = run.agent, run.env, run.agent.config
    horizon, space = env.max_steps(run.params), env.goal_space
    before, after = run.state(e - 1), run.state(e)
    l0, l1 = int(before.low.buffer.size), int(after.low.buffer.size)
    h0, h1 = int(before.high.buffer.size), int(after.high.buffer.size)
    assert l1 - l0 == length, "D_L gets exactly one transition per step"
    low = _rows(run.final.low.buffer.data, l0, l1)
    high = _rows(run.final.high.buffer.data, h0, h1)
    s, g, a, s2 = low["s"], low["c"], low["a"], low["s2"]

    # the environment's reward, next state and termination, recomputed from (s, t, a)
    step = _env_step(env, state_cls)
    obs, r_env, term = map(np.asarray, step(run.params, s, np.arange(length, dtype=np.int32),
                                            np.asarray(agent.env_action(jnp.asarray(a)))))
    np.testing.assert_allclose(s2, obs, rtol=1e-6, atol=1e-6)
    np.testing.assert_array_equal(low["terminated"], term)
    # consecutive steps chain (to rounding: a build without XLA's common-subexpression
    # elimination computes the stored next state and the next stored state apart)
    np.testing.assert_allclose(s[1:], s2[:-1], rtol=1e-6, atol=1e-7)
    assert np.all(np.abs(a) <= 1.0)  # unit actions are stored
    # D_L rewards: r_int = -|P (s' - g)|
    sel = list(space.indices)
    np.testing.assert_allclose(low["r"], -np.linalg.norm(s2[:, sel] - g[:, sel], axis=-1),
                               rtol=1e-5, atol=1e-6)
    off = [i for i in range(env.obs_dim) if i not in sel]
    np.testing.assert_array_equal(g[:, off], 0.0)  # goal entries outside P are 0

    # segments: switch points are cut by the stored durations
    starts, stops, k, cut = [], [], 0, False
    new_goal = np.concatenate([[True], np.any(g[1:] != g[:-1], axis=-1)])
    if with_high:
        assert h1 - h0 >= 1
        for i, u in enumerate(high["a"]):
            T = _unit_to(c.duration_min, c.duration_max, u[-1])
            assert c.duration_min <= T <= c.duration_max
            n = int(np.clip(np.round(T), 1, horizon - k))
            cut = bool(np.round(T) > horizon - k)
            stop = min(k + n, length)  # the last segment ends at the horizon or termination
            goal = np.zeros(env.obs_dim, np.float32)
            goal[sel] = _unit_to(np.asarray(space.low), np.asarray(space.high), u[:-1])
            np.testing.assert_allclose(g[k:stop], np.broadcast_to(goal, g[k:stop].shape),
                                       rtol=1e-6, atol=1e-6)
            np.testing.assert_array_equal(high["s"][i], s[k])  # s_ti
            # s_ti+1, to rounding (as the chain of states above)
            np.testing.assert_allclose(high["s2"][i], s2[stop - 1], rtol=1e-6, atol=1e-7)
            assert high["terminated"][i] == term[stop - 1]
            f = r_env[k:stop].sum() - c.switch_cost * (i > 0)
            np.testing.assert_allclose(high["r"][i], f, rtol=1e-5, atol=1e-5)
            starts.append(k), stops.append(stop)
            k = stop
            assert k < length or i == h1 - h0 - 1, "D_H holds only this episode's segments"
        assert k == length, "the segments cover the episode"
        # the goal is held for the segment and changes at every switch
        np.testing.assert_array_equal(np.flatnonzero(new_goal), starts)
        # the stored D_H rewards sum to the episode's return
        ret = float(run.metrics["return"][e - 1])
        np.testing.assert_allclose(ret, high["r"].sum(), rtol=1e-5, atol=1e-4)
    else:  # pre-training: D_H stores nothing; the segments show in D_L's goals
        assert h1 == h0
        starts = list(np.flatnonzero(new_goal))
        stops = starts[1:] + [length]
    m = {key: float(v[e - 1]) for key, v in run.metrics.items()}
    assert m["length"] == length
    np.testing.assert_allclose(m["env_return"], r_env.sum(), rtol=1e-5, atol=1e-4)
    np.testing.assert_allclose(m["return"], m["env_return"] - c.switch_cost * m["switches"],
                               rtol=1e-5, atol=1e-4)
    assert m["switches"] == len(starts) - 1
    return Episode(s, g, r_env, starts, stops, cut)


def check_trajectory(agent: HIDDPG, traj: dict, metrics: dict, horizon: int) -> list:
    """An evaluation trajectory: switches at 0 and then every ``clip(round(T), 1, steps
    left)`` steps with ``T`` decoded at the previous switch; goal and ``T`` held in between;
    nothing after the episode's end. Returns the segment lengths."""
    c, space = agent.config, agent.env.goal_space
    traj = {k: np.asarray(v) for k, v in traj.items()}
    alive, end = traj["alive"].astype(bool), int(traj["alive"].sum())
    assert alive[:end].all() and not alive[end:].any()
    k, starts, lengths, cut = 0, [], [], False
    while k < end:
        T = traj["duration"][k]
        assert c.duration_min <= T <= c.duration_max
        n = int(np.clip(np.round(T), 1, horizon - k))
        cut |= np.round(T) > horizon - k
        stop = min(k + n, end)
        np.testing.assert_array_equal(traj["duration"][k:stop], T)
        np.testing.assert_array_equal(traj["goal"][k:stop], np.broadcast_to(
            traj["goal"][k], traj["goal"][k:stop].shape))
        starts.append(k), lengths.append(stop - k)
        k = stop
    np.testing.assert_array_equal(np.flatnonzero(traj["switch"]), starts)
    assert starts[0] == 0 and k == end
    # rewards: the environment's, 0 after the end; r_int against the goal entries
    np.testing.assert_array_equal(traj["reward"][end:], 0.0)
    sel = list(space.indices)
    np.testing.assert_allclose(
        traj["intrinsic_reward"][:end],
        -np.linalg.norm(traj["next_obs"][:end, sel] - traj["goal"][:end], axis=-1),
        rtol=1e-5, atol=1e-6)
    lo, hi = np.asarray(space.low, np.float32), np.asarray(space.high, np.float32)
    assert np.all((traj["goal"] >= lo) & (traj["goal"] <= hi))
    m = {k: float(v) for k, v in metrics.items()}
    assert m["switches"] == len(starts) - 1 and m["length"] == end
    np.testing.assert_allclose(m["env_return"], traj["reward"].sum(), rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(m["return"], m["env_return"] - c.switch_cost * m["switches"],
                               rtol=1e-5, atol=1e-5)
    # the high level's discounted return: Σ_k γ_H^k f_k over the segments
    f = [traj["reward"][a:a + n].sum() - c.switch_cost * (i > 0)
         for i, (a, n) in enumerate(zip(starts, lengths, strict=True))]
    np.testing.assert_allclose(m["high_return_discounted"],
                               sum(c.high.gamma ** i * fi for i, fi in enumerate(f)),
                               rtol=1e-5, atol=1e-5)
    return lengths if not cut else lengths + ["cut"]
