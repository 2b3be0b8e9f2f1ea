"""The high critic's value at both ends of a run's noise-free evaluation episode. A
diagnostic, run by hand.

For each seed of a trained HI-DDPG run (its checkpoint): ``Q_H(s_0, μ_H(s_0))`` at the start
and ``Q_H(s_T, μ_H(s_T))`` at the state the episode ends in, the value a time-limit bootstrap
adds to the last segment's target (:func:`hiddpg.experiments.probes.end_value`), next to the
episode's length, return and last reward. ``--export`` adds the run's values to a JSON record
(one entry per label, replaced when measured again) and prints the record's table
(:func:`hiddpg.experiments.probes.end_value_table`, as docs/diagnosis.md quotes it).

Usage::

    python scripts/end_value.py RUN_DIR [--label LABEL] [--export results/diagnosis/probes/X.json]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from hiddpg.experiments.probes import add_end_values, end_value, end_value_table
from hiddpg.runs import Run, make_trainer
from hiddpg.train import eval_keys


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", help="a HI-DDPG run directory")
    parser.add_argument("--label", default=None, help="the run's name in the record")
    parser.add_argument("--export", default=None, help="a JSON record to add the values to")
    args = parser.parse_args()
    try:
        run = Run.open(args.run)
        trainer = make_trainer(run.config)
        state, done = run.load_checkpoint(trainer)
        out = end_value(trainer, state, eval_keys(0, run.seeds))
    except (FileNotFoundError, ValueError) as err:
        parser.error(str(err))
    print(f"{args.run}: {done} episodes; Q_H at the first and at the last state")
    seeds = {}
    for i, seed in enumerate(run.seeds):
        row = {k: v[i].item() for k, v in out.items()}
        seeds[str(seed)] = row
        print(f"seed {seed}: {row['steps']} steps{' (terminated)' if row['ended_early'] else ''},"
              f" return {row['env_return']:.1f}, last reward {row['last_reward']:.3f};"
              f" Q start {row['q_start']:.1f}, Q end {row['q_end']:.1f}")
    if args.export:
        path = Path(args.export)
        record = json.loads(path.read_text()) if path.exists() else {"runs": []}
        entry = {"run": args.label or run.path.name, "name": run.path.name,
                 "episodes": done, "eval_key": 0, "seeds": seeds}
        record = add_end_values(record, entry)
        path.write_text(json.dumps(record, indent=1) + "\n")
        print(f"wrote {path}")
        print(end_value_table(json.loads(path.read_text())))


if __name__ == "__main__":
    main()
