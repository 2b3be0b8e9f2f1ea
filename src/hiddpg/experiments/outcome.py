"""Where a run's final policy ends its episode: success, early end and last reward, per seed.

The diagnosis records (:mod:`hiddpg.experiments.diagnosis`) hold what training logged: the
evaluation returns and switches. Whether the final policy *solves* a task that has a success
criterion is not among them: on the arm tasks a return near the arm at rest can hide a hand
that stops short, and a collision ends the episode early. :func:`final_outcome` replays one
noise-free episode per seed from the run's checkpoint (evaluation key 0, as ``hiddpg eval``)
and keeps, per seed:

* ``success``: the task's own criterion, on tasks whose parameters have ``success_radius``
  (ArmReach, ArmObstacle): the episode ran to its horizon and its last step's reward, minus the
  hand's distance to the target, is above ``-success_radius``; ``None`` on other tasks;
* ``ended_early``: the episode terminated before the horizon (ArmObstacle: a collision);
* ``final_reward``: the environment's reward on the episode's last step (the arm tasks:
  minus the hand's distance to the target, unless the episode ended in a collision);
* ``env_return``: the episode's environment return. On a deterministic task (every task of
  ours but the randomised-target ArmReach) it is the run's logged evaluation at the
  checkpoint's episode, which the tests use as a cross-check.

The checkpoint must hold exactly ``episodes`` episodes (the study's cut), else the outcome
would describe another policy than the table's row: :class:`ValueError` naming both.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

#: the evaluation key of every outcome (``hiddpg eval``'s default ``--key``)
EVAL_KEY = 0


def episode_outcomes(traj: dict[str, Any], horizon: int, success_radius: float | None
                     ) -> dict[str, list]:
    """Per seed (leading axis of ``traj``: alive, reward), the outcome fields above."""
    alive = np.asarray(traj["alive"]).astype(bool)
    reward = np.asarray(traj["reward"], dtype=float)
    steps = alive.sum(axis=1)
    last = np.maximum(steps - 1, 0)
    final_reward = reward[np.arange(len(last)), last]
    env_return = np.where(alive, reward, 0.0).sum(axis=1)
    ended_early = steps < horizon
    success = ([None] * len(last) if success_radius is None
               else ((final_reward > -success_radius) & ~ended_early).tolist())
    return {"success": success, "ended_early": ended_early.tolist(),
            "final_reward": final_reward.tolist(), "env_return": env_return.tolist()}


def final_outcome(path: str | Path, episodes: int) -> dict[str, Any]:
    """The outcome of the run in ``path`` after ``episodes`` episodes (its checkpoint's):
    ``{"episodes", "eval_key", "seeds", "success", "ended_early", "final_reward",
    "env_return"}``, one entry per seed in the lists."""
    from hiddpg.runs import Run
    from hiddpg.train import eval_keys, make_trainer

    run = Run.open(path)
    done = run.checkpoint_episodes()
    if done != episodes:
        raise ValueError(f"{run.path}: its checkpoint holds {done} episodes, not {episodes}; "
                         "the final outcome is of the policy the study's cut ends with "
                         "(cut at the run's last checkpoint, or leave out --final)")
    trainer = make_trainer(run.config)
    if not hasattr(trainer, "env_params"):
        raise ValueError(f"{run.path}: {run.config.task} is a Gymnasium task; the final "
                         "outcome is measured on the JAX engine's tasks only")
    state, _ = run.load_checkpoint(trainer)
    _, traj = trainer.evaluate_seeds(state, eval_keys(EVAL_KEY, run.seeds))
    env, params = trainer.env, trainer.env_params
    radius = getattr(params, "success_radius", None)
    found = episode_outcomes({k: np.asarray(traj[k]) for k in ("alive", "reward")},
                             env.max_steps(params), None if radius is None else float(radius))
    return {"episodes": episodes, "eval_key": EVAL_KEY, "seeds": list(run.seeds), **found}


def summary(final: dict[str, Any]) -> dict[str, Any]:
    """The table's cells of one record's outcome: ``final_success`` and
    ``final_ended_early`` as ``(count, seeds)``, ``final_reward`` as ``(mean, std)``."""
    n = len(final["seeds"])
    out: dict[str, Any] = {}
    if all(s is not None for s in final["success"]):
        out["final_success"] = (sum(final["success"]), n)
    out["final_ended_early"] = (sum(final["ended_early"]), n)
    values = np.asarray(final["final_reward"], dtype=float)
    out["final_reward"] = (float(values.mean()),
                           float(values.std(ddof=1)) if n > 1 else 0.0)
    return out
