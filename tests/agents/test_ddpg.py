"""Flat DDPG learns the known values of the probe environments (``probes.py``).

Small networks and high learning rates keep each run to a few seconds; the asserted numbers are
the probes' exact answers. The engine-facing contract (masking, learning-rate decay, evaluate,
determinism, vmap over seeds) is tested in ``test_ddpg_contract.py``.
"""

from __future__ import annotations

import functools
from typing import Any, NamedTuple

import jax
import numpy as np
import probes
import pytest

from hiddpg.agents.base import EPISODE_KEYS
from hiddpg.agents.ddpg import DDPGAgent, DDPGState, make_ddpg
from hiddpg.configs import DDPGConfig, NoiseConfig

#: small, fast settings: the probes are easy, so learn quickly.
SMALL = dict(hidden=(32, 32), actor_lr=1e-3, critic_lr=1e-2, tau=0.05, batch_size=64,
             buffer_size=2000, learning_starts=64, noise=NoiseConfig(sigma=0.3))

#: name -> (probe, episodes, config overrides)
RUNS = {
    "constant": (probes.ConstantReward(), 300, {}),
    "obs": (probes.ObsReward(), 300, {}),
    "action": (probes.ActionReward(), 1000, dict(actor_lr=3e-3)),
    "two_step": (probes.TwoStep(), 300, dict(gamma=0.9)),
}


class Run(NamedTuple):
    agent: DDPGAgent
    params: Any
    state: DDPGState
    metrics: dict


@functools.cache
def trained(name: str) -> Run:
    env, episodes, cfg_overrides = RUNS[name]
    agent = make_ddpg(DDPGConfig(**{**SMALL, **cfg_overrides}), env)
    params = env.default_params()
    state, metrics = probes.make_train(agent, params, episodes)(jax.random.PRNGKey(0))
    return Run(agent, params, state, metrics)


def q_value(run: Run, obs: float, action: float | None = None) -> float:
    return probes.q_value(run.agent, run.state, obs, action)


def test_a_constant_reward_learns_q_equal_one():
    run = trained("constant")
    assert q_value(run, 0.0) == pytest.approx(1.0, abs=0.05)
    for a in (-0.9, 0.0, 0.9):  # the value does not depend on the action
        assert q_value(run, 0.0, a) == pytest.approx(1.0, abs=0.1)
    np.testing.assert_array_equal(run.metrics["return"], 1.0)
    np.testing.assert_array_equal(run.metrics["length"], 1)
    assert set(EPISODE_KEYS) <= set(run.metrics)


def test_b_obs_reward_learns_q_equal_obs():
    run = trained("obs")
    assert q_value(run, 1.0) == pytest.approx(1.0, abs=0.05)
    assert q_value(run, -1.0) == pytest.approx(-1.0, abs=0.05)


def test_c_action_reward_learns_the_best_action_and_its_value():
    run = trained("action")
    assert probes.policy(run.agent, run.state, 0.0) == pytest.approx(0.5, abs=0.05)
    assert q_value(run, 0.0) == pytest.approx(0.0, abs=0.02)
    assert q_value(run, 0.0, 0.0) < q_value(run, 0.0) - 0.1  # Q peaks near the optimum
    # the buffer stores the applied (unit-box) actions next to their rewards
    buf, n = run.state.buffer, int(run.state.buffer.size)
    a, r = np.asarray(buf.data.action[:n, 0]), np.asarray(buf.data.reward[:n])
    np.testing.assert_allclose(r, -((a - 0.5) ** 2), rtol=1e-6, atol=1e-7)
    metrics, _ = run.agent.evaluate(jax.random.PRNGKey(1), run.state, run.params)
    assert float(metrics["return"]) > -0.0025


def test_d_two_step_learns_the_discounted_value():
    run = trained("two_step")
    assert q_value(run, 0.0) == pytest.approx(0.9, abs=0.05)   # γ · 1
    assert q_value(run, 1.0) == pytest.approx(1.0, abs=0.05)
    np.testing.assert_array_equal(run.metrics["return"], 1.0)
