"""Whether a trained HI-DDPG run's low level still depends on its goals (its checkpoint). A
diagnostic, run by hand.

For each seed: on evenly spaced transitions of the low level's replay buffer, the share of its
noise-free unit actions at a bound, their mean size, how much they change when the goal is
swapped for another stored goal, and their spread over states
(:func:`hiddpg.experiments.saturation.low_saturation`). ``--export`` adds the run to a JSON
record (one entry per label, replaced when measured again) and prints the record's table, as
docs/diagnosis-arm.md quotes it.

Usage::

    python scripts/low_saturation.py RUN_DIR [--label LABEL] \
        [--export results/diagnosis/probes/X.json]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from hiddpg.experiments.probes import add_end_values
from hiddpg.experiments.saturation import low_saturation, saturation_table
from hiddpg.runs import Run, make_trainer


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
        out = low_saturation(trainer, state)
    except (FileNotFoundError, ValueError) as err:
        parser.error(str(err))
    seeds = {str(seed): {k: v[i].item() for k, v in out.items()}
             for i, seed in enumerate(run.seeds)}
    entry = {"run": args.label or run.path.name, "name": run.path.name, "episodes": done,
             "seeds": seeds}
    record = {"runs": [entry]}
    if args.export:
        path = Path(args.export)
        record = add_end_values(json.loads(path.read_text()) if path.exists() else {"runs": []},
                                entry)
        path.write_text(json.dumps(record, indent=1) + "\n")
        print(f"wrote {path}")
    print(saturation_table(record))


if __name__ == "__main__":
    main()
