"""The circular replay buffer: wrap-around, masked inserts, uniform sampling, vmap."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from hiddpg.agents import buffer as replay


def _transition(i):
    i = jnp.asarray(i, jnp.float32)
    return {"obs": jnp.stack([i, -i]), "reward": i, "terminated": i > 3}


EXAMPLE = _transition(0)


def _bitwise_equal(a, b):
    a, b = np.asarray(a), np.asarray(b)
    assert a.dtype == b.dtype and a.shape == b.shape
    assert a.tobytes() == b.tobytes()


def _fill(buf, values):
    for v in values:
        buf = replay.add(buf, _transition(v))
    return buf


def test_init_is_empty_with_the_example_shapes_and_dtypes():
    buf = replay.init(EXAMPLE, 5)
    assert buf.capacity == 5
    assert buf.data["obs"].shape == (5, 2) and buf.data["reward"].shape == (5,)
    assert buf.data["terminated"].dtype == jnp.bool_
    assert int(buf.pos) == 0 and int(buf.size) == 0
    with pytest.raises(ValueError, match="capacity"):
        replay.init(EXAMPLE, 0)


def test_wrap_around_overwrites_the_oldest():
    buf = _fill(replay.init(EXAMPLE, 5), range(1, 8))  # 7 inserts into 5 slots
    np.testing.assert_array_equal(buf.data["reward"], [6, 7, 3, 4, 5])
    np.testing.assert_array_equal(buf.data["obs"][:, 1], [-6, -7, -3, -4, -5])
    np.testing.assert_array_equal(buf.data["terminated"], [True, True, False, True, True])
    assert int(buf.pos) == 2 and int(buf.size) == 5


def test_masked_insert_leaves_the_buffer_bitwise_unchanged():
    buf = _fill(replay.init(EXAMPLE, 4), [1.5, 2.5, 3.5])
    add = jax.jit(replay.add)
    same = add(buf, _transition(9.0), jnp.asarray(False))
    jax.tree_util.tree_map(_bitwise_equal, buf, same)
    changed = add(buf, _transition(9.0), jnp.asarray(True))
    assert float(changed.data["reward"][3]) == 9.0 and int(changed.size) == 4


def test_sampling_is_uniform_over_the_filled_part_only():
    buf = _fill(replay.init(EXAMPLE, 100), range(1, 8))  # slots 7..99 hold zeros
    batch = replay.sample(buf, jax.random.PRNGKey(0), 14_000)
    r = np.asarray(batch["reward"])
    assert set(np.unique(r)) == set(range(1, 8))
    freq = np.bincount(r.astype(int), minlength=8)[1:] / r.size
    np.testing.assert_allclose(freq, 1 / 7, atol=0.015)
    # the fields of one sample come from the same slot
    np.testing.assert_array_equal(batch["obs"][:, 0], r)
    np.testing.assert_array_equal(batch["terminated"], r > 3)


def test_sampling_a_full_buffer_reaches_every_slot():
    buf = _fill(replay.init(EXAMPLE, 6), range(1, 10))
    r = np.asarray(replay.sample(buf, jax.random.PRNGKey(1), 3000)["reward"])
    assert set(np.unique(r)) == {4, 5, 6, 7, 8, 9}


def test_vmap_over_buffers_equals_separate_buffers():
    bufs = [_fill(replay.init(EXAMPLE, 3), range(1, 1 + n)) for n in (0, 2, 4)]
    stacked = jax.tree_util.tree_map(lambda *x: jnp.stack(x), *bufs)
    trans = jax.vmap(_transition)(jnp.array([10.0, 20.0, 30.0]))
    mask = jnp.array([True, False, True])
    out = jax.jit(jax.vmap(replay.add))(stacked, trans, mask)
    keys = jax.random.split(jax.random.PRNGKey(2), 3)
    batches = jax.vmap(replay.sample, in_axes=(0, 0, None))(out, keys, 5)
    for i, buf in enumerate(bufs):
        t = jax.tree_util.tree_map(lambda x, i=i: x[i], trans)
        single = replay.add(buf, t, mask[i])
        jax.tree_util.tree_map(_bitwise_equal, single,
                               jax.tree_util.tree_map(lambda x, i=i: x[i], out))
        batch = replay.sample(single, keys[i], 5)
        np.testing.assert_array_equal(batch["reward"], batches["reward"][i])
    assert [int(s) for s in out.size] == [1, 2, 3]
    assert [int(p) for p in out.pos] == [1, 2, 2]
