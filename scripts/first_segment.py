"""The high level's critic vs the truth for a run's first segment. A diagnostic, run by hand.

For each seed of a trained HI-DDPG run: the actor's first goal and duration at the start state,
then for each duration ``T`` the critic's ``Q_H(s_0, (g, T))`` next to the true high-level
return of holding ``g`` for ``T`` steps and then following the learned high level, noise-free
(:func:`hiddpg.experiments.probes.first_segment`). ``--goal`` probes another goal (e.g. the
reference's) instead of the actor's.

Usage::

    python scripts/first_segment.py RUN_DIR [--durations 1,5,10,14,18,22,26,29,30]
                                            [--goal 1.5,0.35]
"""

from __future__ import annotations

import argparse

import numpy as np

from hiddpg.experiments.probes import first_segment
from hiddpg.runs import Run, make_trainer
from hiddpg.train import eval_keys


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", help="a HI-DDPG run directory")
    parser.add_argument("--durations", default="1,5,10,14,18,22,26,29,30")
    parser.add_argument("--goal", default=None, help="goal entries, comma-separated")
    args = parser.parse_args()
    try:
        durations = [float(x) for x in args.durations.split(",")]
        goal = None if args.goal is None else [float(x) for x in args.goal.split(",")]
    except ValueError:
        parser.error(f"--durations {args.durations!r} and --goal {args.goal!r} must be "
                     "comma-separated numbers")
    run = Run.open(args.run)
    trainer = make_trainer(run.config)
    state, done = run.load_checkpoint(trainer)
    try:
        out = first_segment(trainer, state, eval_keys(0, run.seeds), durations, goal)
    except ValueError as err:
        parser.error(str(err))
    print(f"{args.run}: {done} episodes; Q = critic, f = truth (goals used)")
    for i, seed in enumerate(run.seeds):
        pol = {k: v[i] for k, v in out["policy"].items()}
        own = "(" + ", ".join(f"{x:.2f}" for x in np.asarray(pol["goal"])) + ")"
        g = own if goal is None else "(" + ", ".join(f"{x:g}" for x in goal) + ")"
        rows = zip(durations, out["q"][i], out["return"][i], out["goals"][i], strict=True)
        table = "  ".join(f"T{t:g} Q {q:.1f} f {f:.1f} ({n})" for t, q, f, n in rows)
        print(f"seed {seed}: actor g {own} T {pol['duration']:.1f}"
              f" Q {pol['q']:.1f} f {pol['return']:.1f} | g {g}: {table}")


if __name__ == "__main__":
    main()
