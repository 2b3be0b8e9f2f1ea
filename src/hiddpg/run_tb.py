"""A run's TensorBoard log: one event directory per seed, ``tb/seed_<s>/``.

Scalars go under ``train/<key>`` (one point per training episode) and ``eval/<key>`` (one per
evaluation). Without tensorboardX installed the log is skipped with one warning.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np


class TensorBoardLog:
    """The event writers of one run's seeds, opened on first use."""

    def __init__(self, root: Path, seeds: tuple[int, ...]) -> None:
        self.root, self.seeds = root, seeds
        self._writers: dict[int, Any] | None = None

    def write(self, train: dict[str, np.ndarray], evals: dict[str, np.ndarray]) -> None:
        """One chunk: ``train`` arrays are (seeds, episodes), ``evals`` (seeds, evals)."""
        if self._writers is None:
            self._writers = _open_writers(self.root, self.seeds)
        if not self._writers:
            return
        for i, seed in enumerate(self.seeds):
            w = self._writers[seed]
            for e, ep in enumerate(np.asarray(train["episode"][i])):
                for k, v in train.items():
                    if k != "episode":
                        w.add_scalar(f"train/{k}", float(np.asarray(v)[i, e]), int(ep))
            for e, ep in enumerate(np.asarray(evals["episode"][i])):
                for k, v in evals.items():
                    if k != "episode":
                        w.add_scalar(f"eval/{k}", float(np.asarray(v)[i, e]), int(ep))
            w.flush()

    def close(self) -> None:
        for w in (self._writers or {}).values():
            w.close()
        self._writers = None


def _open_writers(root: Path, seeds: tuple[int, ...]) -> dict[int, Any]:
    try:
        from tensorboardX import SummaryWriter
    except ImportError:
        print("warning: tensorboardX is not installed; skipping TensorBoard logs "
              "(pip install 'hiddpg[tb]')", file=sys.stderr)
        return {}
    return {s: SummaryWriter(logdir=str(root / f"seed_{s}")) for s in seeds}
