"""HI-DDPG's bookkeeping (paper Alg. 1, spec §2): segments, switch costs, the two buffers and
masking after termination. Training episodes are checked through the agent's public state:
``D_L`` holds every step ``(s, g, a, r_int, s')`` and ``D_H`` every segment
``(s_ti, (g, T), f, s_ti+1)``, so the segments of an episode can be rebuilt from the stored
high-level actions alone and compared with what the low level saw and with the environment's
rewards, recomputed here."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hi_ddpg_checks import check_episode, check_trajectory
from hi_ddpg_support import (
    BASE,
    COST,
    EPISODES,
    HORIZON,
    STARTS,
    Reach,
    _count,
    _random_high_actor,
    _run,
    base_run,
    puck_run,
)

from hiddpg.agents.base import EPISODE_KEYS
from hiddpg.agents.hi_ddpg import make_hiddpg


@pytest.mark.parametrize("kind", ["reach", "puck"])
def test_evaluate_switches_every_decoded_duration(kind):
    run = puck_run() if kind == "puck" else base_run()
    evaluate = jax.jit(run.agent.evaluate)
    horizon = run.env.max_steps(run.params)
    all_lengths = []  # (evaluation cannot learn: it returns no state)
    states = [("init", run.init)] + [("random", _random_high_actor(run.init, i)) for i in (1, 2)]
    for name, state in states:
        for seed in range(3):
            metrics, traj = evaluate(jax.random.PRNGKey(seed), state, run.params)
            assert set(EPISODE_KEYS) <= set(metrics)
            assert not any("loss" in k for k in metrics)
            assert traj["obs"].shape[0] == horizon
            lengths = check_trajectory(run.agent, traj, metrics, horizon)
            if name == "init":  # a fresh actor outputs ~0: T is the middle of its range
                mid = (run.agent.config.duration_min + run.agent.config.duration_max) / 2
                np.testing.assert_allclose(np.asarray(traj["duration"]), mid, atol=0.05)
            all_lengths.append(lengths)
    flat = [n for lengths in all_lengths for n in lengths if n != "cut"]
    assert len(set(flat)) >= 3, "the random actors give varied durations"
    assert any("cut" in lengths for lengths in all_lengths), "some segment hits the horizon"


def test_evaluate_is_masked_after_termination():
    run = base_run(terminate_at=9)
    state = _random_high_actor(run.final, 1)
    metrics, traj = jax.jit(run.agent.evaluate)(jax.random.PRNGKey(3), state, run.params)
    np.testing.assert_array_equal(traj["alive"], [1] * 9 + [0] * 3)
    np.testing.assert_array_equal(np.asarray(traj["reward"])[9:], 0.0)
    assert not np.asarray(traj["switch"])[9:].any()
    assert float(metrics["length"]) == 9
    check_trajectory(run.agent, traj, metrics, HORIZON)


def test_evaluate_reports_the_high_critics_value_of_its_first_choice():
    run = base_run()
    agent, choice = run.agent, run.agent.choice
    evaluate = jax.jit(agent.evaluate)
    values = []
    for i, state in enumerate([run.final, _random_high_actor(run.final, 1)]):
        key = jax.random.PRNGKey(i)
        metrics, traj = evaluate(key, state, run.params)
        hobs = choice.inputs(traj["obs"][0], jnp.asarray(HORIZON), HORIZON)
        action = choice.propose(state.high, hobs, jnp.asarray(HORIZON))
        q = choice.q(state.high, hobs, action)
        np.testing.assert_allclose(metrics["high_q_start"], q, rtol=1e-5, atol=1e-6)
        values.append(float(q))
    assert values[0] != values[1]


# -- (a), (b), (c) training episodes -----------------------------------------------------------
def test_train_segments_buffers_and_returns():
    run = base_run()
    seen, cuts = [], 0
    for e in range(1, EPISODES + 1):
        ep = check_episode(run, e, HORIZON)
        seen.append([b - a for a, b in zip(ep.starts, ep.stops, strict=True)])
        cuts += ep.cut
    # after one episode: D_H has one entry per segment, D_L one per step
    first = run.state(1)
    assert int(first.high.buffer.size) == len(seen[0]) == run.metrics["switches"][0] + 1
    assert int(first.low.buffer.size) == HORIZON
    # the random phase draws durations uniformly: varied lengths, and cuts at the horizon
    lengths = {n for ep in seen for n in ep}
    assert len(lengths) >= 4 and cuts >= 1
    assert int(run.final.high.buffer.size) == sum(len(ep) for ep in seen)
    np.testing.assert_array_equal(run.metrics["env_steps"], HORIZON * np.arange(1, 7))
    np.testing.assert_array_equal(run.metrics["length"], HORIZON)
    np.testing.assert_array_equal(run.states.episodes, np.arange(1, 7))


def test_end_is_terminal_flags_the_time_limit_per_level():
    """Truncated episodes: by default nothing is terminal; ``high.end_is_terminal`` flags the
    last segment of every episode in D_H (the paper's arm rule), the low level keeps
    bootstrapping unless it asks too."""
    run = base_run()
    assert not run.final.high.buffer.data.terminated.any()
    assert not run.final.low.buffer.data.terminated.any()
    cfg = dataclasses.replace(BASE, high=dataclasses.replace(BASE.high, end_is_terminal=True))
    flagged = _run(make_hiddpg(cfg, Reach()), Reach(), EPISODES)
    high = flagged.final.high.buffer
    terminal = np.asarray(high.data.terminated[: int(high.size)])
    assert int(terminal.sum()) == EPISODES  # exactly one per episode: its last segment
    assert not flagged.final.low.buffer.data.terminated.any()
    cfg = dataclasses.replace(cfg, low=dataclasses.replace(BASE.low, end_is_terminal=True))
    low = _run(make_hiddpg(cfg, Reach()), Reach(), EPISODES).final.low.buffer
    np.testing.assert_array_equal(np.asarray(low.data.terminated[: EPISODES * HORIZON]),
                                  np.tile([0] * (HORIZON - 1) + [1], EPISODES))


def test_low_level_can_bootstrap_through_a_termination():
    """``low.env_terminal=False``: a collision does not end the low level's (intrinsic) value,
    so it cannot escape its costs by terminating; the high level still sees the termination."""
    cfg = dataclasses.replace(BASE, low=dataclasses.replace(BASE.low, env_terminal=False))
    run = _run(make_hiddpg(cfg, Reach()), Reach(), EPISODES, terminate_at=9)
    low, high = run.final.low.buffer, run.final.high.buffer
    assert int(low.size) == 9 * EPISODES  # the episodes still end at the termination
    assert not np.asarray(low.data.terminated[: int(low.size)]).any()
    assert int(np.asarray(high.data.terminated[: int(high.size)]).sum()) == EPISODES


def test_returns_subtract_the_switch_cost():
    run = base_run()
    m = run.metrics
    assert np.all(m["switches"] >= 1)  # so that the cost matters
    np.testing.assert_allclose(m["return"], m["env_return"] - COST * m["switches"], rtol=1e-5)


# -- (e) learning_starts ------------------------------------------------------------------------


def test_steps_after_termination_are_masked():
    run = base_run(terminate_at=9)
    high_updates = 0
    for e in range(1, EPISODES + 1):
        ep = check_episode(run, e, 9)  # 9 inserts into D_L, one D_H entry per segment
        low = run.final.low.buffer.data.terminated
        np.testing.assert_array_equal(low[9 * (e - 1): 9 * e], [0] * 8 + [1])
        first = max(STARTS - 9 * (e - 1), 0)
        high_updates += sum(first <= stop - 1 for stop in ep.stops)
        state = run.state(e)
        assert _count(state.low) == max(9 * e - STARTS, 0)  # no update after termination
        assert _count(state.high) == high_updates
    # the last segment of every episode ends with the termination
    high = run.final.high.buffer
    assert int(high.data.terminated[: int(high.size)].sum()) == EPISODES
    np.testing.assert_array_equal(run.metrics["length"], 9)
    np.testing.assert_array_equal(run.metrics["env_steps"], 9 * np.arange(1, 7))


# -- (d), (h) PuckTrajectory1: pre-training bypass; HI-DDPG-wo-model --------------------------
