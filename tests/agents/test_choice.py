"""The paper's high-level action ``(g, T)``: the unit box decoded onto the goal bounds and the
durations, exactly at the ends, for any bounds (:class:`hiddpg.agents.choice.Chooser`)."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hi_ddpg_support import (
    BASE,
    PUCK,
    Reach,
)

from hiddpg.agents.hi_ddpg import HIDDPG, make_hiddpg
from hiddpg.envs.base import GoalSpace
from hiddpg.envs.puckworld import PuckTrajectory1


def _decode_ends(agent: HIDDPG):
    d = agent.goal_dim + 1
    return agent.decode(-jnp.ones(d)), agent.decode(jnp.ones(d)), agent.decode(jnp.zeros(d))


@pytest.mark.parametrize("env", [Reach(), PuckTrajectory1()], ids=["reach", "puck"])
def test_decode_maps_the_unit_box_onto_the_goal_bounds_and_durations(env):
    cfg = PUCK if isinstance(env, PuckTrajectory1) else BASE
    agent = make_hiddpg(cfg, env)
    space = env.goal_space
    (g_lo, t_lo), (g_hi, t_hi), (g_mid, t_mid) = jax.device_get(_decode_ends(agent))
    sel = list(space.indices)
    off = [i for i in range(env.obs_dim) if i not in sel]
    assert g_lo.shape == (env.obs_dim,)
    np.testing.assert_array_equal(g_lo[sel], np.float32(space.low))
    np.testing.assert_array_equal(g_hi[sel], np.float32(space.high))
    np.testing.assert_array_equal(g_lo[off], 0.0)
    np.testing.assert_array_equal(g_hi[off], 0.0)
    assert float(t_lo) == cfg.duration_min and float(t_hi) == cfg.duration_max
    np.testing.assert_allclose(g_mid[sel], (np.array(space.low) + space.high) / 2, rtol=1e-6)
    np.testing.assert_allclose(t_mid, (cfg.duration_min + cfg.duration_max) / 2, rtol=1e-6)
    # in between, the map is affine
    u = np.linspace(-1.0, 1.0, 9, dtype=np.float32)
    goals, durations = jax.vmap(agent.decode)(jnp.stack([u] * (agent.goal_dim + 1), -1))
    w = (u[:, None] + 1) / 2
    np.testing.assert_allclose(np.asarray(goals)[:, sel],
                               (1 - w) * np.array(space.low) + w * np.array(space.high),
                               rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(durations, (1 - w[:, 0]) * cfg.duration_min
                               + w[:, 0] * cfg.duration_max, rtol=1e-6)


class OddBounds(Reach):
    """Bounds whose float32 difference rounds: ``lo + (hi - lo)`` is not ``hi``."""

    goal_space = GoalSpace((0, 2), (-1.3, -2.7), (0.7, 1.9))


def test_decode_is_exact_at_the_ends_for_any_bounds():
    cfg = dataclasses.replace(BASE, duration_min=1.3, duration_max=7.9)
    agent = make_hiddpg(cfg, OddBounds())
    (g_lo, t_lo), (g_hi, t_hi), _ = jax.device_get(_decode_ends(agent))
    space = agent.env.goal_space
    np.testing.assert_array_equal(g_lo[[0, 2]], np.float32(space.low))
    np.testing.assert_array_equal(g_hi[[0, 2]], np.float32(space.high))
    assert t_lo == np.float32(1.3) and t_hi == np.float32(7.9)


# -- (a), (b) evaluate ---------------------------------------------------------------------------
