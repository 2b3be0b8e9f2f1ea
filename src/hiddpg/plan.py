"""What a training run will do, said before it starts: :func:`describe`; and a duration in
words, :func:`eta_text`.

``describe(make_config("hi-ddpg", "PuckTrajectory1", "quick", []), range(5))`` reads::

    hi-ddpg on PuckTrajectory1 (preset quick): 5 seeds × 1,500 episodes = 7,500 episodes, at
    most 225,000 environment steps in training; evaluation every 10 episodes; checkpoint about
    6.6 MB after every 100 episodes

The step bound is the episodes times the task's horizon (``max_steps`` of its params, env
overrides applied); the checkpoint size is the bytes of the run state's leaves, read from
``jax.eval_shape`` of :meth:`hiddpg.train.Trainer.init_seeds` (nothing is compiled or run).
"""

from __future__ import annotations

from collections.abc import Sequence

import jax
import numpy as np

from hiddpg.configs import TrainConfig
from hiddpg.presets import task_name
from hiddpg.train import Trainer


def plural(n: int, word: str) -> str:
    """``1 seed``, ``5 seeds``, ``1,500 episodes`` (thousands separated)."""
    return f"{n:,} {word}" if n == 1 else f"{n:,} {word}s"


def eta_text(seconds: float) -> str:
    """A duration in words: ``under a minute``, ``about 3 min``, ``about 2 h 10 min``."""
    if not np.isfinite(seconds):
        return "unknown"
    minutes = round(seconds / 60.0)
    if seconds < 60.0 or minutes < 1:
        return "under a minute"
    if minutes < 60:
        return f"about {minutes} min"
    hours, minutes = divmod(minutes, 60)
    return f"about {hours} h" + (f" {minutes} min" if minutes else "")


def size_text(nbytes: float) -> str:
    """``310 kB``, ``6.6 MB``, ``73 MB``, ``1.2 GB`` (decimal units; one decimal below 10)."""
    for unit, scale in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if nbytes >= scale:
            value = nbytes / scale
            return f"{value:.1f} {unit}" if value < 10 else f"{value:.0f} {unit}"
    return f"{nbytes:.0f} B"


def state_bytes(trainer: Trainer, n_seeds: int) -> int:
    """The bytes of the leaves of ``trainer``'s run state of ``n_seeds`` seeds (about a
    checkpoint's size), from the shapes alone."""
    key = jax.eval_shape(lambda: jax.random.PRNGKey(0))
    keys = jax.ShapeDtypeStruct((n_seeds, *key.shape), key.dtype)
    state = jax.eval_shape(trainer.init_seeds, keys)
    return int(sum(int(np.prod(leaf.shape)) * np.dtype(leaf.dtype).itemsize
                   for leaf in jax.tree.leaves(state)))


def describe(config: TrainConfig, seeds: Sequence[int], done: int = 0) -> str:
    """One paragraph on what training ``config`` on ``seeds`` from ``done`` episodes does:
    the episodes (the remaining ones for a resumed run), the most environment steps in
    training, how often it evaluates and how big its checkpoint is and how often it is
    written."""
    from hiddpg.runs import make_trainer

    trainer = make_trainer(config)
    n_seeds = len(list(seeds))
    setting = f"preset {config.preset}"
    if config.env:
        setting += ", env " + ", ".join(f"{k}={v!r}" for k, v in config.env)
    remaining = max(config.episodes - done, 0)
    work = f"{plural(n_seeds, 'seed')} × {plural(config.episodes, 'episode')}"
    if done:
        work += f" from episode {done:,} = {plural(n_seeds * remaining, 'episode')} to go"
    else:
        work += f" = {plural(n_seeds * remaining, 'episode')}"
    steps = n_seeds * remaining * trainer.env.max_steps(trainer.env_params)
    size = size_text(state_bytes(trainer, n_seeds))
    chunk = max(trainer.chunk_sizes(0))
    return (f"{config.algo} on {task_name(config.task)} ({setting}): {work}, at most "
            f"{steps:,} environment steps in training; evaluation every "
            f"{plural(config.eval_every, 'episode')}; checkpoint about {size} after every "
            f"{plural(chunk, 'episode')}")
