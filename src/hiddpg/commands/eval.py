"""``hiddpg eval``: replay a run's learned policies without noise, optionally as a GIF.

::

    hiddpg eval DIR [--seed S] [--gif FILE] [--key K]

Loads ``DIR``'s config and checkpoint, runs one noise-free, non-learning episode per seed
(:meth:`hiddpg.train.Trainer.evaluate_seeds`) and prints per seed the columns ``return`` (the
agent's return: for HI-DDPG the high-level return, ``env_return`` minus the switch cost of
every goal after the first; for the other algorithms ``env_return``), ``env_return`` (the sum
of the environment's rewards), ``switches`` and ``length``, then their mean and standard
deviation over the seeds. ``--gif FILE`` draws seed ``S``'s episode (default: the run's first
seed) with :mod:`hiddpg.render`: HI-DDPG's current goal and its switch points, h-DDPG's
current skill and the steps where it changed, the ``env_return`` so far, and a legend. A
Gymnasium task's run (``gym:<id>``, :mod:`hiddpg.host`) is drawn by the environment itself, its
``render_mode="rgb_array"`` frames of the replayed episode (:mod:`hiddpg.host.gif`); one that
cannot draw them is said so before anything is evaluated (exit code 2). Its declaration (goal,
skills) comes from the run directory.

``--gif`` must name a file ending in ``.gif`` that is not a directory; its missing parent
directories are created. ``DIR`` and ``--gif`` are checked before anything is loaded: a bad
one prints one line naming it and exits with code 2.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from types import SimpleNamespace
from typing import Any

import numpy as np

from hiddpg.commands.common import Parser as _Parser
from hiddpg.commands.common import UsageError, run_command
from hiddpg.host.declare import declarations_scope
from hiddpg.host.task import is_gym_task
from hiddpg.paths import existing_dir, gif_path
from hiddpg.runs import Run, make_trainer
from hiddpg.train import eval_keys

PROG = "hiddpg eval"
#: GIF frame rate cap: the arm (50 control steps/s) plays at half speed.
MAX_FPS = 25.0
COLUMNS = ("return", "env_return", "switches", "length")
#: What the table's columns are, printed under it.
COLUMN_NOTE = ("return: the agent's return (HI-DDPG: the high-level return, env_return minus "
               "the switch costs; other algorithms: env_return); env_return: the sum of the "
               "environment's rewards (the GIF's running number)")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog=PROG, description="Replay a run's learned policies without noise.")
    p.add_argument("run", metavar="DIR", help="a run directory written by `hiddpg train`")
    p.add_argument("--seed", type=int, default=None,
                   help="only this seed (default: all); the GIF's seed (default: the first)")
    p.add_argument("--gif", default=None, metavar="FILE.gif",
                   help="write the episode as an animated GIF (a name ending in .gif; missing "
                   "directories are created)")
    p.add_argument("--key", type=int, default=0,
                   help="evaluation key: seed s is evaluated with fold_in(PRNGKey(K), s)")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``hiddpg eval`` with ``argv``; returns the exit code (2 on a bad command line)."""
    with declarations_scope():  # a run's Gymnasium declaration, for this command only
        return run_command(PROG, argv, build_parser, _open, _evaluate,
                           errors=(UsageError, ValueError, FileNotFoundError))


def _open(args: argparse.Namespace) -> tuple[Run, Any, Any, int]:
    """The run to evaluate, its trainer and its checkpointed state and episodes; a usage error
    if the GIF path is unusable, or the run directory, the seed or the checkpoint is missing
    (the paths are checked first), and a one-line error naming a checkpoint or config that
    cannot be read (:class:`hiddpg.run_files.RunFileError`), or a Gymnasium task's
    environment cannot draw the GIF."""
    if args.gif is not None:
        args.gif = gif_path(args.gif, "--gif")
    run = Run.open(existing_dir(args.run, "DIR"))
    if args.seed is not None and args.seed not in run.seeds:
        raise UsageError(f"--seed {args.seed} is not in the run; its seeds are "
                         f"{list(run.seeds)}")
    if not run.checkpoint_path.is_file():
        raise UsageError(f"{run.path} has no checkpoint yet")
    trainer = make_trainer(run.config)
    state, done = run.load_checkpoint(trainer)
    if _drawn_by_gymnasium(args, run, trainer):
        from hiddpg.host.gif import open_renderer

        open_renderer(trainer.env).close()  # it can draw: checked before evaluating
    return run, trainer, state, done


def _drawn_by_gymnasium(args: argparse.Namespace, run: Run, trainer: Any) -> bool:
    """The GIF is the environment's own frames: a Gymnasium task, not one of our adapters."""
    return (args.gif is not None and is_gym_task(run.config.task)
            and trainer.env.core is None)


def _evaluate(args: argparse.Namespace, opened: tuple[Run, Any, Any, int]) -> int:
    """Evaluate every seed from the checkpoint, print the table and write the GIF."""
    run, trainer, state, done = opened
    keys = eval_keys(args.key, run.seeds)
    metrics, traj = trainer.evaluate_seeds(state, keys)
    metrics = {k: np.asarray(v) for k, v in metrics.items()}
    shown = [args.seed] if args.seed is not None else list(run.seeds)
    print(f"{run.config.algo} on {run.config.task}, {done} episodes, noise-free evaluation")
    print(f"{'seed':>6}" + "".join(f"{c:>12}" for c in COLUMNS))
    for seed in shown:
        i = run.seeds.index(seed)
        print(f"{seed:>6}" + "".join(f"{_fmt(metrics[c][i], c):>12}" for c in COLUMNS))
    if len(shown) > 1:
        print(f"{'mean':>6}" + "".join(f"{metrics[c].mean():>12.3f}" for c in COLUMNS))
        print(f"{'std':>6}" + "".join(f"{metrics[c].std(ddof=1):>12.3f}" for c in COLUMNS)
              + "  (over seeds)")
    print(COLUMN_NOTE)
    if args.gif is not None:
        seed = shown[0]
        i = run.seeds.index(seed)
        one = {k: np.asarray(v)[i] for k, v in traj.items()}
        title = (f"{run.config.algo} seed {seed}, {done} episodes: "
                 f"env_return {float(metrics['env_return'][i]):.2f}")
        if _drawn_by_gymnasium(args, run, trainer):
            from hiddpg.host.gif import open_renderer, write_host_gif

            path, note = write_host_gif(trainer.env, open_renderer(trainer.env), one, keys[i],
                                        args.gif, title)
            if note:
                print(note)
        elif is_gym_task(run.config.task):  # one of our tasks through its adapter
            env = trainer.env
            drawn = SimpleNamespace(env=env.core, env_params=env.params)
            path = write_episode_gif(drawn, one, args.gif, title)
        else:
            path = write_episode_gif(trainer, one, args.gif, title)
        print(f"wrote {path}")
    return 0


def _fmt(v: Any, column: str) -> str:
    v = float(np.asarray(v))
    return str(int(v)) if column in ("switches", "length") and v.is_integer() else f"{v:.3f}"


def write_episode_gif(trainer: Any, traj: dict[str, np.ndarray], path: str, title: str):
    """Draw one evaluation episode (trajectory arrays of one seed) with a legend and write it as
    a GIF."""
    from hiddpg import render

    env, params = trainer.env, trainer.env_params
    n = max(int(np.asarray(traj["alive"]).sum()), 1)
    obs = np.asarray(traj["obs"])[:n]
    if "next_obs" in traj:  # the state after the last action too
        obs = np.concatenate([obs, np.asarray(traj["next_obs"])[n - 1:n]])
    states = obs[:, :env.state_dim]  # every task observes its physical state first
    target = obs[0, env.state_dim:env.state_dim + 2] if env.obs_dim > env.state_dim else None
    kwargs: dict[str, Any] = dict(actions=np.asarray(traj["action"])[:n],
                                  rewards=np.asarray(traj["reward"])[:n], title=title,
                                  target=target)
    if "goal" in traj:  # HI-DDPG: the current goal, switch points marked
        goal = np.asarray(traj["goal"])[:n]
        if goal.shape[-1] == env.obs_dim != env.goal_space.dim:
            goal = goal[..., list(env.goal_space.indices)]
        kwargs.update(goals=goal, goal_label="learned goal")
        if "switch" in traj:
            kwargs["switches"] = np.asarray(traj["switch"])[:n].astype(bool)
    elif "skill" in traj:  # h-DDPG: the current skill, changes marked
        skill = np.asarray(traj["skill"])[:n]
        flat = skill.reshape(len(skill), -1)
        kwargs.update(switches=np.r_[True, np.any(flat[1:] != flat[:-1], axis=-1)],
                      notes=[f"skill {s.tolist()}" for s in skill], switch_label="skill change")
    frames = render.render_rollout(env, params, states, **kwargs)
    return render.write_gif(frames, path, fps=min(1.0 / env.dt, MAX_FPS))


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
