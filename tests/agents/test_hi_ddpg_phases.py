"""HI-DDPG's phases and options (spec §2): nothing learns before ``learning_starts``,
low-level pre-training bypasses the high level (and may fill ``D_H``), HI-DDPG-wo-model never
changes its models, the high-level noise follows its schedule; the same key gives the same
run bit for bit and a vmap over seeds equals the single runs."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
from hi_ddpg_checks import check_episode
from hi_ddpg_support import (
    BASE,
    EPISODES,
    HORIZON,
    PUCK,
    PUCK_EPISODES,
    PUCK_STARTS,
    STARTS,
    Reach,
    _compiled,
    _count,
    _equal,
    _params,
    _run,
    base_run,
    puck_agent,
    puck_run,
)

from hiddpg.agents import make_agent
from hiddpg.agents.hi_ddpg import make_hiddpg
from hiddpg.configs import EagerHighLevel, NoiseConfig
from hiddpg.envs.puckworld import PuckState, PuckTrajectory1


def test_nothing_learns_before_learning_starts():
    run = base_run()
    for e in (1, 2):  # 24 < 30 steps: every learnt quantity is bitwise the initial one
        state = run.state(e)
        assert _equal(_params(state.low), _params(run.init.low))
        assert _equal(_params(state.high), _params(run.init.high))
        for lv in ("high", "low"):
            for loss in ("critic_loss", "actor_loss", "model_loss"):
                assert float(run.metrics[f"{lv}_{loss}"][e - 1]) == 0.0
    # episode 3 runs env steps 24..35: the low level updates at 30..35, the high level at the
    # segment ends among them; then both update at every step / segment end
    expected_high = 0
    for e in range(3, EPISODES + 1):
        ep = check_episode(run, e, HORIZON)
        first = max(STARTS - HORIZON * (e - 1), 0)  # first step of the episode that learns
        expected_high += sum(stop - 1 >= first for stop in ep.stops)
        state = run.state(e)
        assert _count(state.low) == HORIZON * e - STARTS
        assert int(state.low.block.critic_opt.count) == HORIZON * e - STARTS
        assert int(state.low.model.opt_state.count) == HORIZON * e - STARTS
        assert _count(state.high) == expected_high
        assert int(state.high.model.opt_state.count) == expected_high
        assert float(run.metrics["low_critic_loss"][e - 1]) > 0
    assert not _equal(run.final.low.block.actor, run.init.low.block.actor)
    assert not _equal(run.final.high.block.actor, run.init.high.block.actor)
    assert not _equal(run.final.low.model.params, run.init.low.model.params)
    assert not _equal(run.final.high.model.params, run.init.high.model.params)


# -- (f) early termination ----------------------------------------------------------------------


def test_pretraining_bypasses_the_high_level():
    run = puck_run()
    agent, c, horizon = run.agent, run.agent.config, 30
    assert c.pretrain_episodes == 2 and c.learning_starts == PUCK_STARTS
    assert run.env.max_steps(run.params) == horizon
    act = jax.jit(jax.vmap(lambda st, s: agent.high.act(st, s, jnp.zeros((0,))),
                           in_axes=(None, 0)))
    lengths = []
    for e in (1, 2):
        state = run.state(e)
        # the high level (networks, optimisers, model and D_H) is bitwise untouched
        assert _equal(state.high, run.init.high)
        ep = check_episode(run, e, horizon, PuckState, with_high=False)
        # goals are uniform draws, not the high actor's output
        own = np.asarray(jax.vmap(lambda u: agent.decode(u)[0])(
            act(run.init.high, ep.s[ep.starts])))
        assert np.all(np.abs(ep.goal[ep.starts] - own)[:, :2].min(-1) > 1e-3)
        lengths += [b - a for a, b in zip(ep.starts, ep.stops, strict=True)]
    assert len(set(lengths)) >= 3  # uniform durations (the actor's would all be 5)
    # while the low level learns, from step 6 on
    assert _count(run.state(1).low) == horizon - PUCK_STARTS
    assert _count(run.state(2).low) == 2 * horizon - PUCK_STARTS
    assert not _equal(run.state(2).low.block, run.init.low.block)

    # episode 3: the (noise-free) high actor chooses the first goal; the high level learns
    ep = check_episode(run, 3, horizon, PuckState)
    goal, duration = jax.vmap(agent.decode)(act(run.init.high, ep.s[:1]))
    np.testing.assert_allclose(ep.goal[0], goal[0], rtol=1e-6, atol=1e-7)
    assert ep.stops[0] == round(float(duration[0])) == 5
    n3 = len(ep.starts)
    assert int(run.state(3).high.buffer.size) == n3
    assert _count(run.state(3).high) == n3  # one update per segment end (high_learning_starts 1)
    assert not _equal(run.state(3).high.block.actor, run.init.high.block.actor)
    ep4 = check_episode(run, 4, horizon, PuckState)
    assert _count(run.state(4).high) == n3 + len(ep4.starts)
    assert _count(run.state(4).low) == 4 * horizon - PUCK_STARTS
    # the puck episode terminates at the horizon: each episode's last segment is terminal
    high = run.final.high.buffer
    np.testing.assert_array_equal(np.flatnonzero(high.data.terminated[: int(high.size)]),
                                  [n3 - 1, n3 + len(ep4.starts) - 1])
    m = run.metrics
    np.testing.assert_allclose(m["return"], m["env_return"] - 10.0 * m["switches"], rtol=1e-5)
    np.testing.assert_array_equal(m["length"], horizon)


def test_wo_model_never_changes_the_models():
    run = puck_run()
    assert run.agent.config.model_weight == 0.0 and not run.agent.config.use_model
    for e in range(1, PUCK_EPISODES + 1):
        for lv in ("high", "low"):
            assert _equal(getattr(run.state(e), lv).model, getattr(run.init, lv).model)
            assert float(run.metrics[f"{lv}_model_loss"][e - 1]) == 0.0
    assert _count(run.final.high) > 0 and _count(run.final.low) > 0  # the rest learned


# -- (i) determinism, vmap over seeds ----------------------------------------------------------
def test_same_key_gives_bitwise_the_same_run():
    run = base_run()
    f = _compiled(run.agent, EPISODES)
    again = jax.device_get(f(run.init, jax.random.PRNGKey(0), run.params))
    assert _equal(again, (run.states, run.metrics))
    other = jax.device_get(f(run.init, jax.random.PRNGKey(1), run.params))
    assert not np.array_equal(other[1]["env_return"], run.metrics["env_return"])


def test_vmap_over_seeds_equals_single_runs():
    """On the PuckTrajectory1 agent (2 pre-training episodes, then both levels learn)."""
    agent = puck_agent()
    singles = [puck_run(seed=i) for i in range(2)]
    inits = jax.tree_util.tree_map(lambda *x: jnp.stack(x), *(r.init for r in singles))
    keys = jnp.stack([jax.random.PRNGKey(0), jax.random.PRNGKey(1)])
    states, metrics = jax.device_get(
        _compiled(agent, PUCK_EPISODES, batched=True)(inits, keys, singles[0].params))
    for i, single in enumerate(singles):
        for k in metrics:
            np.testing.assert_allclose(metrics[k][i], single.metrics[k], rtol=1e-6, atol=1e-6,
                                       err_msg=k)
        # float32 sums are ordered differently under vmap: 1e-6 of each array's scale
        jax.tree_util.tree_map(
            lambda x, y, i=i: np.testing.assert_allclose(
                x[i], y, rtol=1e-6, atol=1e-6 * max(1.0, np.max(np.abs(y), initial=0.0))),
            states, single.states)
    assert not np.array_equal(metrics["return"][0], metrics["return"][1])




def test_pretraining_can_fill_the_high_buffer():
    """``EagerHighLevel.pretraining_segments``: the pre-training segments (random goals and
    durations) go into D_H with their true rewards and end states, while the high level still
    learns nothing until pre-training ends."""
    config = dataclasses.replace(PUCK, eager_high=EagerHighLevel(every_step=False))
    agent = make_agent("hi-ddpg-wo-model", config, PuckTrajectory1())
    run = _run(agent, PuckTrajectory1(), 3)
    for e in (1, 2):
        assert _equal(_params(run.state(e).high), _params(run.init.high))
        ep = check_episode(run, e, 30, PuckState)  # D_H holds exactly this episode's segments
        assert len(ep.starts) >= 2
    assert not _equal(_params(run.state(3).high), _params(run.init.high))
    assert int(run.state(2).high.buffer.size) > 0


def test_high_level_noise_follows_its_schedule():
    """A high-level noise decaying from 0.5 to 0 over 2 episodes: the first goal of episode 1
    is off the actor's, from episode 3 on it is the actor's own (the schedule reaches the
    agent through its episode count)."""
    decaying = NoiseConfig(sigma=0.5, final_sigma=0.0, decay_episodes=2)
    config = dataclasses.replace(
        BASE, learning_starts=0,
        high=dataclasses.replace(BASE.high, noise=decaying))
    agent = make_hiddpg(config, Reach())
    run = _run(agent, Reach(), 4)
    act = jax.jit(lambda st, s: agent.decode(agent.high.act(st, s, jnp.zeros((0,))))[0])
    for e, noisy in ((1, True), (3, False), (4, False)):
        ep = check_episode(run, e, HORIZON)
        own = np.asarray(act(run.state(e - 1).high, ep.s[0]))
        gap = np.abs(ep.goal[0] - own)[[0, 2]].max()
        assert (gap > 1e-3) if noisy else (gap < 1e-5), (e, gap)

