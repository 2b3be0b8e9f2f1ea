"""Named random streams: one split, one sub-key per name, no name twice."""

from __future__ import annotations

import jax
import numpy as np
import pytest

from hiddpg.agents.hi_ddpg_state import STREAMS, step_keys
from hiddpg.agents.streams import split_named


def test_each_name_gets_its_own_sub_key_of_one_split():
    key = jax.random.PRNGKey(3)
    keys = split_named(key, ("a", "b", "c"))
    np.testing.assert_array_equal(np.stack(list(keys.values())), jax.random.split(key, 3))
    assert list(keys) == ["a", "b", "c"]


def test_a_repeated_name_is_refused():
    with pytest.raises(ValueError, match=r"repeat a name"):
        split_named(jax.random.PRNGKey(0), ("noise", "env", "noise"))


def test_hi_ddpg_draws_every_purpose_from_a_different_key():
    keys = step_keys(jax.random.PRNGKey(0))
    assert set(STREAMS) <= set(keys)
    raw = {tuple(np.asarray(k).tolist()) for k in keys.values()}
    assert len(raw) == len(keys)
