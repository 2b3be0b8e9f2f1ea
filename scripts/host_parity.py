"""Statistical parity of the two engines: the same config trained by the JAX engine on one of
our tasks and by the host loop on its Gymnasium adapter (``gym:hiddpg/<task>-v0``), on the
same seeds; each seed's final return (the mean of its last evaluations) per engine, the mean
and its 95% t-interval, and whether each engine's mean lies in the other's interval.

    python scripts/host_parity.py --algo h-ddpg --task PuckTrajectory1 --episodes 100
    python scripts/host_parity.py --algo hi-ddpg --task PuckTrajectory1 --preset quick

Exit status 1 if a mean lies outside the other engine's interval. With several seeds the two
engines need not run the same floating-point programs (the JAX engine maps its seeds inside one
compiled scan, the host loop runs each seed's steps on their own), so their runs may diverge
and the comparison is statistical; with one seed the host loop gives the JAX engine's numbers
(tests/host/test_host_parity.py).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time

import numpy as np
from scipy import stats

from hiddpg.host import HostTrainer
from hiddpg.presets import make_config
from hiddpg.train import Trainer, seed_keys


def final_returns(trainer, seeds: list[int], last: int) -> np.ndarray:
    """Each seed's mean evaluation return over its ``last`` evaluations."""
    state, evals = trainer.init_seeds(seed_keys(seeds)), []
    for n in trainer.chunk_sizes():
        state, _, eval_m = trainer.run_chunk_seeds(state, n)
        evals.append(np.asarray(eval_m["return"]))
    return np.concatenate(evals, axis=1)[:, -last:].mean(axis=1)


def interval(x: np.ndarray) -> tuple[float, float, float]:
    """Mean and its 95% t-interval."""
    mean, half = x.mean(), stats.t.ppf(0.975, len(x) - 1) * x.std(ddof=1) / np.sqrt(len(x))
    return float(mean), float(mean - half), float(mean + half)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--algo", default="h-ddpg")
    parser.add_argument("--task", default="PuckTrajectory1")
    parser.add_argument("--preset", default="quick")
    parser.add_argument("--episodes", type=int, help="training episodes (default: preset's)")
    parser.add_argument("--seeds", type=int, default=5, help="seeds 0..N-1")
    parser.add_argument("--last", type=int, default=3, help="evaluations averaged per seed")
    parser.add_argument("--set", action="append", default=[], dest="sets",
                        help="a config override, as for hiddpg train --set")
    args = parser.parse_args(argv)
    sets = list(args.sets) + ([f"episodes={args.episodes}"] if args.episodes else [])
    config = make_config(args.algo, args.task, args.preset, sets)
    host = dataclasses.replace(config, task=f"gym:hiddpg/{config.task}-v0")
    seeds, rows = list(range(args.seeds)), {}
    for name, trainer in (("jax", Trainer(config)), ("host", HostTrainer(host))):
        t0 = time.perf_counter()
        rows[name] = final_returns(trainer, seeds, args.last)
        print(f"{name:>4}: {interval(rows[name])[0]:9.2f} [{interval(rows[name])[1]:9.2f}, "
              f"{interval(rows[name])[2]:9.2f}]  per seed {np.round(rows[name], 2).tolist()}  "
              f"({time.perf_counter() - t0:.0f} s)", flush=True)
    (m_jax, lo_jax, hi_jax), (m_host, lo_host, hi_host) = (interval(rows["jax"]),
                                                           interval(rows["host"]))
    ok = lo_jax <= m_host <= hi_jax and lo_host <= m_jax <= hi_host
    print(f"{args.algo} {config.task} {args.preset}, {config.episodes} episodes, seeds "
          f"0-{args.seeds - 1}: each mean within the other's 95% interval: {ok}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
