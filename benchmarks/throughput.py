"""Training throughput of flat DDPG and HI-DDPG against Stable-Baselines3 (run by hand, not a test).

    .venv/bin/python benchmarks/throughput.py                  # prints the table
    .venv/bin/python benchmarks/throughput.py --write          # ... and writes docs/performance.md
    .venv/bin/python benchmarks/throughput.py --pieces         # ... and times the parts of a step
    .venv/bin/python benchmarks/throughput.py --algos ddpg --seeds 1 --no-sb3   # a quick look

What is measured (all on CPU, default thread settings unless said otherwise):

* **ours**: :class:`hiddpg.train.Trainer` with the ``paper`` preset on ``PuckTrajectory2``
  (actor, critic and models 300-300, batch 64) and ``agent.learning_starts=0`` (so every step
  learns from the first one), for 1 and 15 seeds. ``init_seeds``, then one chunk of
  ``--episodes`` episodes (compilation), then ``--repeats`` further chunks, each timed to
  ``block_until_ready``. Environment steps = seeds x episodes x 30 (the evaluation episode
  that closes a chunk is not counted, its time is).
* **SB3**: ``stable_baselines3.DDPG`` on ``gym.make("hiddpg/PuckTrajectory2-v0")`` (our
  Gymnasium adapter), CPU torch, ``net_arch`` 300-300 for actor and critic, batch 64,
  ``train_freq=1``, ``gradient_steps=1``, ``learning_starts=0``, in a fresh process (so no JAX
  thread pool competes with torch's), once with torch's default threads and once with one
  thread; the ratios divide by the stronger of the two (per wall-clock second and per
  CPU-second separately). A short ``learn`` warms up, then
  ``learn(--sb3-steps)`` is timed. Skipped with a message when SB3 is not installed
  (``pip install -e ".[bench]"``; not a dependency of hiddpg's own extras).

Steps per second are given per wall-clock second (best and median of the repeats) and per
CPU-second of this process (``time.process_time``, all threads), which stays meaningful when
other jobs share the cores; CPU/wall > 1 means more than one core was busy.

The fraction of the matrix-multiply peak divides the matmul FLOPs a step executes
(``flops_per_step``, formula in ``benchmarks/flops.py``) by NumPy's GFLOP/s on the same matmul
shapes (float32, forward ``(B, in) @ (in, out)``, weight gradient ``(in, B) @ (B, out)``, input
gradient ``(B, out) @ (out, in)``), timed in fresh processes with one BLAS thread (one core)
and with the default threads (the machine; multi-threaded OpenBLAS collapses on small shapes
when another job holds a core, so the machine figure is at least cores x the one-thread one).
The FLOP formula is cross-checked against XLA's own cost analysis of one jitted update.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

from hiddpg.devices import request_cpu_devices

request_cpu_devices()  # as the hiddpg command does: one CPU device per core (hiddpg.devices)

import jax  # noqa: E402  (after the device request)
import numpy as np  # noqa: E402
from _timing import (  # noqa: E402
    DOC,
    Row,
    bench_config,
    every_step,
    high_updates_per_step,
    load,
    sb3_learn,
    strongest,
    time_chunks,
    worker,
)
from _timing import time_sb3 as _time_sb3  # noqa: E402
from _timing import write_section as _write_section  # noqa: E402
from flops import flops_per_step, numpy_gflops, xla_update_flops  # noqa: E402

from hiddpg.train import Trainer  # noqa: E402

TASK = "PuckTrajectory2"
HORIZON = 30  # PuckTrajectory2's episode length (checked against the env below)
SECTION = "## Training throughput"

def _numpy_worker(algo: str) -> dict:
    trainer = None if algo == "sb3" else Trainer(ours_config(algo, 1, 1))
    return {"same": numpy_gflops(flops_per_step(algo, trainer).matmuls),
            "big": numpy_gflops({(1024, 1024, 1024): 4})}


def numpy_rates(algo: str, threads: int | None) -> dict:
    """NumPy GFLOP/s on ``algo``'s matmul shapes (``same``) and on 1024² (``big``), measured
    in a fresh process (no JAX threads around) with ``threads`` BLAS threads (None: default).
    On a loaded machine multi-threaded OpenBLAS can collapse (its threads spin-wait for a core
    someone else holds), so both one thread and the default are measured."""
    env = dict(os.environ)
    if threads is not None:
        for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
            env[var] = str(threads)
    return _worker(["numpy", algo], env)


def _worker(args: list[str], env: dict | None = None) -> dict:
    return worker(__file__, args, env)


# -- timing --------------------------------------------------------------------------------------
def ours_config(algo: str, episodes: int, repeats: int):
    return bench_config(algo, TASK, episodes, repeats)


NAMES = {"ddpg": "DDPG (ours)", "hi-ddpg": "HI-DDPG (ours), Alg. 1: H updates at segment ends",
         "h-ddpg": "h-DDPG (ours)",
         "hi-ddpg@every-step": "HI-DDPG (ours), H updates at every step (`eager_high`)"}


def time_ours(algo: str, seeds: int, episodes: int, repeats: int) -> Row:
    trainer = Trainer(ours_config(algo, episodes, repeats))
    horizon = trainer.env.max_steps(trainer.env_params)
    assert horizon == HORIZON, horizon
    walls, cpus, compile_s, out = time_chunks(trainer, seeds, episodes, repeats)
    steps = int(np.asarray(out[1]["length"]).sum())  # seeds x episodes x 30
    assert steps == seeds * episodes * HORIZON, steps
    high = high_updates_per_step(trainer.config, out[1], steps)  # one H update per segment
    return Row(NAMES.get(algo, algo), seeds, steps, walls, cpus,
               flops_per_step(algo, trainer, high).flops, compile_s=compile_s,
               note=f"{high:.3f} high-level updates per step" if high < 1 else "")


def _sb3_worker(threads: int, steps: int, warmup: int, repeats: int) -> dict:
    return sb3_learn("DDPG", f"hiddpg/{TASK}-v0", [300, 300], 64, threads, steps, warmup,
                     repeats)


def time_sb3(threads: int | None, steps: int, warmup: int, repeats: int) -> Row | str:
    """SB3 DDPG in a fresh process (torch's threads then compete with no JAX threads);
    ``threads=None`` keeps torch's default. A string says why it was skipped."""
    args = ["sb3", str(threads or 0), str(steps), str(warmup), str(repeats)]
    return _time_sb3(__file__, args, "DDPG", threads, steps, flops_per_step("sb3").flops)


# -- report --------------------------------------------------------------------------------------
def machine(loads: tuple[float, float]) -> str:
    device = jax.devices()[0]
    cpu = platform.processor() or platform.machine()
    return (f"{device.platform.upper()}, {os.cpu_count()} CPU cores ({cpu}), jax "
            f"{jax.__version__}, numpy {np.__version__}; 1-minute load average "
            f"{loads[0]:.1f} at the start and {loads[1]:.1f} at the end of the run")


def markdown(rows: list[Row], base: tuple[Row, Row] | None, skip: str, args: argparse.Namespace,
             loads: tuple[float, float], xla: dict[str, tuple[int, float | None]],
             big: tuple[float, float]) -> str:
    head = ("| run | seeds | env steps/s (wall, best) | median | per CPU-second | CPU/wall | "
            "÷ SB3 (wall) | ÷ SB3 (CPU) | matmul MFLOP/step | GFLOP/s | % of NumPy, 1 core | "
            "% of NumPy, machine | load |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
            "---:|---:|---:|\n")
    body = ""
    for r in rows:
        ratio = f"{r.rate / base[0].rate:.1f}×" if base else "n/a"
        cpu_ratio = f"{r.cpu_rate / base[1].cpu_rate:.1f}×" if base else "n/a"
        body += (f"| {r.name} | {r.seeds} | {r.rate:,.0f} | {r.median_rate:,.0f} | "
                 f"{r.cpu_rate:,.0f} | {r.cores:.2f} | {ratio} | {cpu_ratio} | "
                 f"{r.flops / 1e6:.0f} | {r.gflops:.1f} | "
                 f"{100 * r.gflops / r.core_gflops:.0f}% of {r.core_gflops:.0f} | "
                 f"{100 * r.gflops / r.machine_gflops:.0f}% of {r.machine_gflops:.0f} | "
                 f"{r.load:.1f} |\n")
    checks = "; ".join(
        f"{algo} {ours / 1e6:.0f} MFLOP by the formula, {x / 1e6:.0f} by XLA"
        for algo, (ours, x) in xla.items() if x is not None)
    sb3 = [r for r in rows if r.name.startswith("SB3")]
    sb3_note = sb3[0].note if sb3 else f"SB3 skipped: {skip}"
    base_note = (f"the wall ratio divides by the SB3 row with the most steps per second "
                 f"({base[0].name}), the CPU ratio by the one with the most per CPU-second "
                 f"({base[1].name})" if base else "no SB3 baseline")
    high_on = "step" if every_step(ours_config("hi-ddpg", 1, 1).agent) else "segment"
    cmd = (f".venv/bin/python benchmarks/throughput.py --algos {' '.join(args.algos)} "
           f"--seeds {' '.join(map(str, args.seeds))} --episodes {args.episodes} "
           f"--repeats {args.repeats} --sb3-steps {args.sb3_steps} --write")
    return (
        f"{SECTION}\n\n"
        f"Environment steps per second while training on {TASK} with an update at every "
        "step from the first one (paper preset: actor, critic and models 300-300, batch 64, "
        "`agent.learning_starts=0`), measured by `benchmarks/throughput.py` on "
        f"{machine(loads)}, {time.strftime('%Y-%m-%d')}. Default thread settings for XLA "
        f"(XLA_FLAGS {os.environ.get('XLA_FLAGS', '') or 'unset'}); {sb3_note}.\n\n"
        f"* Ours: `Trainer.run_chunk_seeds` ({len(jax.devices())} XLA CPU devices, one per "
        "core, as the `hiddpg` command sets up; several seeds are sharded over them and run "
        "one after another on each, see `hiddpg.devices`) on chunks of "
        f"{args.episodes} episodes per seed "
        "(+1 evaluation episode, timed but not counted) after a first chunk that compiles; "
        f"best and median of {args.repeats} chunks; steps = seeds × episodes × 30.\n"
        "* SB3: `DDPG('MlpPolicy', gym.make('hiddpg/PuckTrajectory2-v0'))` (our Gymnasium "
        "adapter), net_arch 300-300 for actor and critic, batch 64, train_freq 1, "
        "gradient_steps 1, learning_starts 0, CPU torch, in a fresh process; "
        f"`learn({args.sb3_steps})` after a warm-up, best of {args.repeats}; {base_note}.\n"
        "* Per CPU-second divides by the CPU time of the process (all its threads), which "
        "stays meaningful when other jobs share the cores; CPU/wall is the mean number of "
        "busy cores; load is the 1-minute load average when the row was measured.\n"
        "* Matmul MFLOP per env step by the formula in `benchmarks/flops.py` (HI-DDPG: a low-level "
        f"update every step and, with the preset's high-level updates at every {high_on} "
        "(Alg. 1), a high-level update per segment, counted from the measured segments per "
        "step; with `eager_high.every_step` (`hi-ddpg@every-step`, not the paper) a high-level "
        "update every step too); cross-checked against XLA's cost "
        "analysis of one update (all ops): "
        f"{checks or 'n/a'}. % of NumPy divides the achieved GFLOP/s by NumPy's float32 "
        "GFLOP/s on the same matmul shapes, measured in a fresh process with one BLAS thread "
        "(1 core) and for the machine (the larger of the default-thread measurement and "
        f"{os.cpu_count()} × the one-thread one). NumPy on a 1024² matmul: {big[0]:.0f} GFLOP/s "
        f"with one thread, {big[1]:.0f} with the default threads.\n\n"
        + head + body + f"\nReproduce: `{cmd}`\n"
    )


def write_section(text: str, path: Path = DOC) -> None:
    """Replace (or append) the ``## Training throughput`` section (up to the next ``## ``)."""
    _write_section(text, SECTION, path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=20, help="episodes per seed per chunk")
    parser.add_argument("--repeats", type=int, default=3, help="timed chunks / SB3 runs")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 15])
    parser.add_argument("--algos", nargs="+", default=["ddpg", "hi-ddpg", "h-ddpg"])
    parser.add_argument("--sb3-steps", type=int, default=2000)
    parser.add_argument("--sb3-warmup", type=int, default=200)
    parser.add_argument("--no-sb3", action="store_true")
    parser.add_argument("--pieces", action="store_true",
                        help="also time the parts of a training step (where the time goes)")
    parser.add_argument("--write", action="store_true", help=f"write the section to {DOC}")
    parser.add_argument("--worker", nargs="+", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:  # a subprocess of this script: print one JSON line
        kind, *rest = args.worker
        result = (_numpy_worker(rest[0]) if kind == "numpy"
                  else _sb3_worker(*(int(x) for x in rest)))
        print(json.dumps(result))
        return

    load_start = load()
    print(f"load average {load_start:.2f}; XLA devices {jax.devices()}; "
          f"XLA_FLAGS={os.environ.get('XLA_FLAGS', '') or 'unset'}", flush=True)
    algos = args.algos + ([] if args.no_sb3 else ["sb3"])
    blas = {algo: (numpy_rates(algo, 1), numpy_rates(algo, None)) for algo in algos}
    for algo, (one, default) in blas.items():
        print(f"NumPy float32 GFLOP/s on {algo}'s matmul shapes: {one['same']:.1f} (1 thread), "
              f"{default['same']:.1f} (default threads); 1024²: {one['big']:.1f}, "
              f"{default['big']:.1f}", flush=True)
    big = (max(one["big"] for one, _ in blas.values()),
           max(default["big"] for _, default in blas.values()))

    def with_peaks(row: Row, algo: str) -> Row:
        one, default = blas[algo]
        row.core_gflops = one["same"]
        row.machine_gflops = max(default["same"], (os.cpu_count() or 1) * one["same"])
        return row

    rows, xla = [], {}
    for algo in args.algos:
        trainer = Trainer(ours_config(algo, args.episodes, args.repeats))
        count = flops_per_step(algo, trainer)
        acting = sum(2 * m * k * n * t for (m, k, n), t in count.matmuls.items() if m == 1)
        if "@" not in algo:  # variants share their algorithm's update
            xla[algo] = (count.flops - acting, xla_update_flops(algo, trainer))
        for seeds in args.seeds:
            row = with_peaks(time_ours(algo, seeds, args.episodes, args.repeats), algo)
            rows.append(row)
            print(f"{row.name:16s} x{seeds:2d}: {row.rate:8,.0f} steps/s (median "
                  f"{row.median_rate:,.0f}), {row.cpu_rate:8,.0f} per CPU-s, CPU/wall "
                  f"{row.cores:.2f}, compile + 1st chunk {row.compile_s:.1f} s, "
                  f"{row.gflops:.1f} GFLOP/s", flush=True)

    sb3_rows, skip = [], ""
    if not args.no_sb3:
        for threads in (None, 1):
            sb3 = time_sb3(threads, args.sb3_steps, args.sb3_warmup, args.repeats)
            if isinstance(sb3, str):
                skip = sb3
                print(f"Stable-Baselines3 DDPG skipped: {sb3} "
                      "(.venv/bin/pip install torch stable-baselines3)")
                break
            rows.append(with_peaks(sb3, "sb3"))
            print(f"{sb3.name:16s}: {sb3.rate:8,.0f} steps/s (median {sb3.median_rate:,.0f}), "
                  f"{sb3.cpu_rate:8,.0f} per CPU-s, CPU/wall {sb3.cores:.2f}, "
                  f"{sb3.gflops:.1f} GFLOP/s; {sb3.note}", flush=True)
            sb3_rows.append(sb3)
    else:
        skip = "--no-sb3"
    base = strongest(sb3_rows)  # the strongest baseline: per wall-clock and per CPU-second
    if base:
        for r in rows:
            print(f"  {r.name} x{r.seeds}: {r.rate / base[0].rate:.1f}x SB3 (wall), "
                  f"{r.cpu_rate / base[1].cpu_rate:.1f}x (per CPU-second)")
    for r in rows:
        share = 100 * r.gflops / r.core_gflops
        print(f"  {r.name} x{r.seeds}: {r.gflops:.1f} GFLOP/s = {share:.0f}% of NumPy on one "
              f"core, {100 * r.gflops / r.machine_gflops:.0f}% of the machine (same shapes)")
    ours = [r for r in rows if not r.name.startswith("SB3")]
    busy = [f"{r.name} x{r.seeds} ({r.cores:.2f})" for r in ours if r.cores > 1.2]
    print("XLA CPU kept more than one core busy in: " + (", ".join(busy) or "no run")
          + f" (CPU/wall: {', '.join(f'{r.cores:.2f}' for r in ours)})")
    if args.pieces:
        print("where the time goes (one seed, ms per env step):")
        from pieces import pieces

        pieces(ours_config)

    text = markdown(rows, base, skip, args, (load_start, load()), xla, big)
    print("\n" + text)
    if args.write:
        write_section(text)
        print(f"wrote {DOC}")


if __name__ == "__main__":
    main()
