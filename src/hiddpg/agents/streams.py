"""Named random streams: a key split once, one sub-key per purpose, looked up by name, so that
no key feeds two draws and a reader sees which draw uses which stream."""

from __future__ import annotations

from collections.abc import Sequence

import jax


def split_named(key: jax.Array, names: Sequence[str]) -> dict[str, jax.Array]:
    """``{name: sub-key}``, the sub-keys of ``jax.random.split(key, len(names))`` in order."""
    if len(set(names)) != len(names):
        raise ValueError(f"stream names {list(names)} repeat a name")
    return dict(zip(names, jax.random.split(key, len(names)), strict=True))
