"""The engine: chunk boundaries, one compilation per chunk size, make_train == chunked Trainer."""

import jax
import numpy as np
import pytest

from hiddpg.presets import make_config
from hiddpg.train import Trainer, make_train, seed_keys

TINY = ["episodes=25", "eval_every=5", "chunk_episodes=10", "agent.hidden=[8,8]",
        "agent.learning_starts=40", "agent.buffer_size=200", "agent.batch_size=8"]


@pytest.fixture(scope="module")
def trainer():
    return Trainer(make_config("ddpg", "PuckTrajectory1", "quick", TINY))


def test_chunk_sizes_fall_on_evaluation_boundaries(trainer):
    assert trainer.chunk_sizes() == [10, 10, 5]
    assert trainer.chunk_sizes(20) == [5]
    with pytest.raises(ValueError, match="chunk boundary"):
        trainer.chunk_sizes(7)
    # 15 is no boundary but a multiple of eval_every (a shorter run extended): on to the next
    assert trainer.chunk_sizes(15) == [5, 5]
    with pytest.raises(ValueError, match="30 episodes done"):
        trainer.chunk_sizes(30)
    odd = Trainer(make_config("ddpg", "PuckTrajectory1", "quick",
                              TINY + ["episodes=23", "chunk_episodes=12"]))
    assert odd.chunk_sizes() == [10, 10, 3]


def test_chunks_compile_once_per_size_and_match_make_train(trainer):
    keys = seed_keys([3, 4])
    state = trainer.init_seeds(keys)
    compiled_before = trainer.run_chunk_seeds._cache_size()  # the cache is shared by trainers
    train_ms, eval_ms = [], []
    for n in trainer.chunk_sizes():
        state, tm, em = trainer.run_chunk_seeds(state, n)
        train_ms.append(tm)
        eval_ms.append(em)
    # two chunks of 10 and one of 5: two compilations, not three (no accidental retracing)
    assert trainer.run_chunk_seeds._cache_size() - compiled_before == 2
    returns = np.concatenate([np.asarray(m["return"]) for m in train_ms], axis=1)
    assert returns.shape == (2, 25)
    episodes = np.concatenate([np.asarray(m["episode"]) for m in eval_ms], axis=1)
    np.testing.assert_array_equal(episodes[0], [5, 10, 15, 20, 25])

    _, tm, em = jax.jit(jax.vmap(make_train(trainer.config)))(keys)
    np.testing.assert_allclose(np.asarray(tm["return"]), returns, rtol=1e-5, atol=1e-5)
    np.testing.assert_array_equal(np.asarray(em["episode"])[0], [5, 10, 15, 20, 25])


def test_make_train_holds_one_copy_of_the_evaluation_block_however_many_chunks():
    def program(episodes: int) -> str:
        cfg = make_config("ddpg", "PuckTrajectory1", "quick",
                          TINY + [f"episodes={episodes}", "eval_every=5"])
        return jax.jit(make_train(cfg)).lower(jax.random.PRNGKey(0)).as_text()

    three_chunks, ten_chunks = program(25), program(100)  # chunk_episodes=10
    assert three_chunks.count("stablehlo.while") == ten_chunks.count("stablehlo.while")
    assert abs(len(ten_chunks) - len(three_chunks)) < 0.01 * len(three_chunks)
    # a run short of its last block adds one copy of the block, of that many episodes
    assert program(23).count("stablehlo.while") > three_chunks.count("stablehlo.while")
