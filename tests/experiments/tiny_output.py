"""The tiny reproduction end-to-end test files share: Fig. 4 on PuckTrajectory2
(HI-DDPG, 2 seeds x 20 episodes, hidden [16, 16]). It is trained once per test worker that
needs it (the ``tiny_fig4`` fixture of tests/experiments/conftest.py) and each file works on
its own copy."""

from __future__ import annotations

import shutil
from pathlib import Path

TINY = ["--seeds", "2", "--episodes", "20", "--set", "agent.hidden=[16,16]",
        "--tasks", "PuckTrajectory2"]


def copy_output(source: Path, target: Path) -> Path:
    """A copy of the output ``source`` at ``target`` (its files' times kept), for one file's
    tests to change."""
    shutil.copytree(source, target, symlinks=True)
    return target
