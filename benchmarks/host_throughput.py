"""Training throughput of the host loop on a Gymnasium (MuJoCo) environment against
Stable-Baselines3 (run by hand, not a test).

    .venv/bin/python benchmarks/host_throughput.py             # Reacher-v5, prints the table
    .venv/bin/python benchmarks/host_throughput.py --write     # ... and writes docs/performance.md
    .venv/bin/python benchmarks/host_throughput.py --episodes 2 --repeats 1 --sb3-steps 200 \\
        --seeds 1 2 --env-steps 500                            # a smoke run (a minute or two)

Everything is measured in one run of this script, so that the ratios compare rows measured on
the same CPU under the same load (the absolute numbers move with both). What is measured, all on
CPU, default thread settings unless said otherwise:

* **ours, host loop**: :class:`hiddpg.host.HostTrainer` (our jitted agents, one Gymnasium
  environment per seed in a ``SyncVectorEnv`` stepped in Python, :mod:`hiddpg.host.loop`) on
  ``gym:<--env>`` with the ``paper`` preset, actor, critic (and HI-DDPG's models) ``--hidden``,
  batch ``--batch`` at every level, ``learning_starts=0`` (HI-DDPG also
  ``high_learning_starts=0``, no pre-training), so every environment step updates from the
  first one, as SB3's ``train_freq=1, gradient_steps=1, learning_starts=0`` does; for 1 and N
  seeds (``--seeds``). ``init_seeds``, one chunk of ``--episodes`` episodes per seed
  (compilation), then ``--repeats`` further chunks, each timed (the chunk returns numpy
  metrics). Environment steps = the training episodes' lengths summed over seeds (the
  evaluation episode that closes a chunk is not counted, its time is). HI-DDPG's goal is
  ``--goal INDEX:LOW:HIGH`` (default on Reacher: the fingertip-to-target entries 8 and 9 within
  ±0.3, as in tests/host/test_host_mujoco.py); without one it is skipped on other environments.
* **SB3**: ``stable_baselines3.DDPG`` and ``TD3`` on ``gym.make(--env)``, ``net_arch``
  ``--hidden`` for actor and critic, batch ``--batch``, ``train_freq=1``, ``gradient_steps=1``,
  ``learning_starts=0``, CPU torch, in a fresh process (no JAX thread pool competing), once
  with torch's default threads and once with one thread. ``learn(--sb3-warmup)``, then
  ``--repeats`` timed ``learn(--sb3-steps)``. TD3 is SB3's own: twin critics, the actor and the
  targets updated every second step (``policy_delay=2``). Skipped with a message when SB3 is
  not installed (``pip install -e ".[bench]"``).
* **the environment alone**: ``gym.make(--env)``, ``env.step`` with uniformly random actions
  (drawn beforehand) in a Python loop, reset when an episode ends; and the ``SyncVectorEnv``
  of N environments that the host loop steps (N steps per ``step`` call, a seeded reset every
  horizon). No learner is that fast on the host loop: it bounds any of them.

Steps per second are given per wall-clock second (best and median of the repeats) and per
CPU-second of the process that ran them (``time.process_time``, all threads), which stays
meaningful when other jobs share the cores; CPU/wall > 1 means more than one core was busy.
The ratios divide by the stronger SB3 DDPG row (per wall-clock and per CPU-second separately)
and by the raw ``env.step`` rate of one environment.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import json
import os
import platform
import sys
import time

import numpy as np

from hiddpg.devices import request_cpu_devices

request_cpu_devices()  # as the hiddpg command does: one CPU device per core (hiddpg.devices)

import gymnasium  # noqa: E402
import jax  # noqa: E402  (after the device request)
from _timing import (  # noqa: E402
    DOC,
    Row,
    bench_config,
    cpu_name,
    high_updates_per_step,
    load,
    sb3_learn,
    strongest,
    time_chunks,
    time_sb3,
    timed,
    write_section,
)

from hiddpg.host import HostTrainer, make_host_env, register_gym_task  # noqa: E402

SECTION = "## Host loop (Gymnasium environments)"
#: HI-DDPG's goal on Reacher: fingertip minus target (observation entries 8 and 9)
REACHER_GOAL = {8: (-0.3, 0.3), 9: (-0.3, 0.3)}
NAMES = {"ddpg": "DDPG (ours, host loop)",
         "hi-ddpg": "HI-DDPG (ours, host loop), Alg. 1: H updates at segment ends",
         "hi-ddpg@every-step": "HI-DDPG (ours, host loop), H updates at every step"}
SB3_ALGOS = ("DDPG", "TD3")


# -- ours ----------------------------------------------------------------------------------------
def goal_of(args: argparse.Namespace) -> dict | None:
    """HI-DDPG's goal: ``--goal INDEX:LOW:HIGH ...``, else Reacher's, else None."""
    if args.goal:
        out = {}
        for item in args.goal:
            index, low, high = item.split(":")
            out[int(index)] = (float(low), float(high))
        return out
    return REACHER_GOAL if args.env.startswith("Reacher-") else None


def host_config(algo: str, args: argparse.Namespace):
    """The benchmark config (``learning_starts=0``, :func:`_timing.bench_config`) on
    ``gym:<--env>`` with ``--hidden`` networks and batch ``--batch`` at every level."""
    hidden = f"[{','.join(map(str, args.hidden))}]"
    if algo.startswith("hi-ddpg"):
        sets = [f"agent.{level}.{key}" for level in ("high", "low")
                for key in (f"hidden={hidden}", f"batch_size={args.batch}")]
        sets.append("agent.pretrain_episodes=0")
    else:
        sets = [f"agent.hidden={hidden}", f"agent.batch_size={args.batch}"]
    return bench_config(algo, f"gym:{args.env}", args.episodes, args.repeats, tuple(sets))


def time_host(algo: str, seeds: int, args: argparse.Namespace) -> Row:
    trainer = HostTrainer(host_config(algo, args))
    try:
        walls, cpus, compile_s, out = time_chunks(trainer, seeds, args.episodes, args.repeats)
    finally:
        trainer.close()
    steps = int(np.asarray(out[1]["length"]).sum())
    high = high_updates_per_step(trainer.config, out[1], steps)
    return Row(NAMES.get(algo, algo), seeds, steps, walls, cpus, compile_s=compile_s,
               note=f"{high:.3f} high-level updates per step" if high < 1 else "")


# -- the environment alone -----------------------------------------------------------------------
def time_env(env_id: str, steps: int, repeats: int) -> Row:
    """``env.step`` of one ``gym.make(env_id)`` with random actions in a Python loop."""
    env = gymnasium.make(env_id)
    box = env.action_space
    actions = np.random.default_rng(0).uniform(box.low, box.high, (steps,) + box.shape)
    actions = actions.astype(box.dtype)
    env.reset(seed=0)

    def run() -> None:
        for a in actions:
            _, _, terminated, truncated, _ = env.step(a)
            if terminated or truncated:
                env.reset()

    run()  # warm-up
    walls, cpus = timed(run, repeats)
    env.close()
    return Row("`env.step` alone, random actions", 1, steps, walls, cpus)


def time_vector(env_id: str, n: int, steps: int, repeats: int) -> Row:
    """The ``SyncVectorEnv`` of ``n`` environments the host loop steps (built by
    :meth:`hiddpg.host.HostEnv.make_vector`), random actions, a seeded reset every horizon."""
    host = make_host_env(f"gym:{env_id}")
    vec = host.make_vector(n)
    horizon = host.horizon
    calls = max(1, steps // n)
    rng = np.random.default_rng(0)
    actions = host.to_box(rng.uniform(-1.0, 1.0, (calls, n, host.action_dim)))

    def run() -> None:
        for t in range(calls):
            if t % horizon == 0:
                vec.reset(seed=list(range(n)))
            vec.step(actions[t])

    run()  # warm-up
    walls, cpus = timed(run, repeats)
    vec.close()
    return Row(f"`SyncVectorEnv` of {n} envs (the host loop's), random actions", n, calls * n,
               walls, cpus)


# -- SB3 -----------------------------------------------------------------------------------------
def sb3_rows(args: argparse.Namespace) -> tuple[list[Row], str]:
    """SB3 DDPG and TD3, torch's default threads and one thread; why they were skipped."""
    rows = []
    for algo in SB3_ALGOS:
        for threads in (None, 1):
            worker_args = ["sb3", algo, args.env, ",".join(map(str, args.hidden)),
                           str(args.batch), str(threads or 0), str(args.sb3_steps),
                           str(args.sb3_warmup), str(args.repeats)]
            row = time_sb3(__file__, worker_args, algo, threads, args.sb3_steps)
            if isinstance(row, str):
                print(f"Stable-Baselines3 skipped: {row} "
                      "(.venv/bin/pip install torch stable-baselines3)")
                return rows, row
            report(row)
            rows.append(row)
    return rows, ""


# -- report --------------------------------------------------------------------------------------
def report(row: Row) -> None:
    extra = f", first chunk (compiles) {row.compile_s:.1f} s" if row.compile_s else ""
    print(f"{row.name[:48]:48s} x{row.seeds:2d}: {row.rate:9,.0f} steps/s (median "
          f"{row.median_rate:,.0f}), {row.cpu_rate:9,.0f} per CPU-s, CPU/wall {row.cores:.2f}, "
          f"load {row.load:.1f}{extra}{'; ' + row.note if row.note else ''}", flush=True)


def versions() -> str:
    out = [f"Python {platform.python_version()}"]
    for name in ("hiddpg", "jax", "jaxlib", "numpy", "gymnasium", "mujoco",
                 "stable-baselines3", "torch"):
        try:
            out.append(f"{name} {importlib.metadata.version(name)}")
        except importlib.metadata.PackageNotFoundError:
            out.append(f"{name} not installed")
    return ", ".join(out)


def command(args: argparse.Namespace) -> str:
    cmd = (f".venv/bin/python benchmarks/host_throughput.py --env {args.env} "
           f"--algos {' '.join(args.algos)} --seeds {' '.join(map(str, args.seeds))} "
           f"--episodes {args.episodes} --repeats {args.repeats} "
           f"--hidden {' '.join(map(str, args.hidden))} --batch {args.batch} "
           f"--sb3-steps {args.sb3_steps} --sb3-warmup {args.sb3_warmup} "
           f"--env-steps {args.env_steps}")
    cmd += "".join(f" --goal {g}" for g in args.goal or [])
    return cmd + (" --no-sb3" if args.no_sb3 else "") + " --write"


def markdown(rows: list[Row], base: tuple[Row, Row] | None, env_row: Row, skip: str,
             args: argparse.Namespace, loads: tuple[float, float], horizon: int,
             goal: dict | None) -> str:
    head = ("| run | seeds | env steps/s (wall, best) | median | per CPU-second | CPU/wall | "
            "÷ SB3 DDPG (wall) | ÷ SB3 DDPG (CPU) | ÷ `env.step` (wall) | first chunk (s) | "
            "load |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n")
    body = ""
    for r in rows:
        ratio = f"{r.rate / base[0].rate:.2f}×" if base else "n/a"
        cpu_ratio = f"{r.cpu_rate / base[1].cpu_rate:.2f}×" if base else "n/a"
        first = f"{r.compile_s:.1f}" if r.compile_s else ""
        name = r.name + (f" ({r.note})" if r.note and not r.name.startswith("SB3") else "")
        body += (f"| {name} | {r.seeds} | {r.rate:,.0f} | {r.median_rate:,.0f} | "
                 f"{r.cpu_rate:,.0f} | {r.cores:.2f} | {ratio} | {cpu_ratio} | "
                 f"{r.rate / env_row.rate:.3f} | {first} | {r.load:.1f} |\n")
    hidden = "-".join(map(str, args.hidden))
    goal_text = ("; HI-DDPG's goal: observation entries " + ", ".join(
        f"{i} in [{lo:g}, {hi:g}]" for i, (lo, hi) in sorted(goal.items()))
        if goal else "; HI-DDPG skipped: no goal declared (--goal)")
    base_note = (f"the SB3 ratios divide by the SB3 DDPG row with the most steps per second "
                 f"({base[0].name}) and by the one with the most per CPU-second "
                 f"({base[1].name})" if base else f"no SB3 baseline ({skip})")
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return (
        f"{SECTION}\n\n"
        f"Environment steps per second while training on the Gymnasium environment "
        f"`{args.env}` (horizon {horizon}) with an update at every environment step from the "
        f"first one, measured in one run of `benchmarks/host_throughput.py` (only the ratios "
        f"within a run compare: the CPU and the load change between runs), "
        f"{time.strftime('%Y-%m-%d')}, on {cpu_name()}, {cores} of {os.cpu_count()} cores "
        f"available, 1-minute load average {loads[0]:.1f} at the start and {loads[1]:.1f} at "
        f"the end; {versions()}; {len(jax.devices())} XLA CPU devices (XLA_FLAGS "
        f"`{os.environ.get('XLA_FLAGS', '') or 'unset'}`).\n\n"
        "* Ours: `HostTrainer.run_chunk_seeds` (`hiddpg.host`: our jitted act and learn steps, "
        "one Gymnasium environment per seed in a `SyncVectorEnv` stepped in Python; on CPU "
        "the seeds' jitted steps run one after another), paper preset on "
        f"`gym:{args.env}` with actor, critic (and HI-DDPG's models) {hidden}, batch "
        f"{args.batch} at every level, `learning_starts=0` (HI-DDPG also "
        f"`high_learning_starts=0`, `pretrain_episodes=0`){goal_text}. Chunks of "
        f"{args.episodes} episodes per seed (+1 evaluation episode, timed but not counted) "
        f"after a first chunk that compiles (its seconds in the table); best and median of "
        f"{args.repeats} chunks; steps = the training episodes' lengths summed over seeds.\n"
        f"* SB3: `DDPG` / `TD3('MlpPolicy', gym.make('{args.env}'))`, net_arch {hidden} for "
        f"actor and critic, batch {args.batch}, train_freq 1, gradient_steps 1, "
        "learning_starts 0 (TD3: its twin critics, actor and targets every second step), CPU "
        f"torch, in a fresh process; `learn({args.sb3_steps})` after `learn("
        f"{args.sb3_warmup})`, best and median of {args.repeats}; {base_note}.\n"
        f"* The environment alone: `gym.make('{args.env}')`, `env.step` in a Python loop "
        f"with uniformly random actions drawn beforehand, {args.env_steps} steps, resets "
        "when an episode ends; and the `SyncVectorEnv` the host loop steps for the most "
        "seeds, with a seeded reset every horizon. ÷ `env.step` divides a row's rate by the "
        "single environment's: how close a loop comes to stepping the environment alone.\n"
        "* Per CPU-second divides by the CPU time of the process that ran the row (all its "
        "threads; ours, the environment: this process; SB3: its own), which stays meaningful "
        "when other jobs share the cores; CPU/wall is the mean number of busy cores; load is "
        "the 1-minute load average when the row was measured.\n\n"
        + head + body + f"\nReproduce: `{command(args)}`\n"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="Reacher-v5", help="a Gymnasium id (MuJoCo or other)")
    parser.add_argument("--algos", nargs="+", default=["ddpg", "hi-ddpg"],
                        help="ours: ddpg, hi-ddpg, hi-ddpg@every-step")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 5])
    parser.add_argument("--episodes", type=int, default=10, help="episodes per seed per chunk")
    parser.add_argument("--repeats", type=int, default=3, help="timed chunks / SB3 runs")
    parser.add_argument("--hidden", type=int, nargs="+", default=[300, 300],
                        help="hidden sizes of every actor, critic and model (ours and SB3's)")
    parser.add_argument("--batch", type=int, default=64)
    parser.add_argument("--goal", action="append", metavar="INDEX:LOW:HIGH",
                        help="HI-DDPG's goal entries (default on Reacher: 8 and 9 within ±0.3)")
    parser.add_argument("--sb3-steps", type=int, default=2000)
    parser.add_argument("--sb3-warmup", type=int, default=200)
    parser.add_argument("--env-steps", type=int, default=5000,
                        help="steps per timed run of the environment alone")
    parser.add_argument("--no-sb3", action="store_true")
    parser.add_argument("--write", action="store_true", help=f"write the section to {DOC}")
    parser.add_argument("--worker", nargs="+", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:  # a subprocess of this script: print one JSON line
        _, algo, env_id, hidden, *rest = args.worker
        sizes = [int(h) for h in hidden.split(",")]
        print(json.dumps(sb3_learn(algo, env_id, sizes, *(int(x) for x in rest))))
        return

    load_start = load()
    print(f"{args.env}; load average {load_start:.2f}; {cpu_name()}; XLA devices "
          f"{len(jax.devices())}; XLA_FLAGS={os.environ.get('XLA_FLAGS', '') or 'unset'}; "
          f"{versions()}", flush=True)
    env_row = time_env(args.env, args.env_steps, args.repeats)
    report(env_row)
    rows = [env_row]
    if max(args.seeds) > 1:
        rows.append(time_vector(args.env, max(args.seeds), args.env_steps, args.repeats))
        report(rows[-1])

    goal = goal_of(args)
    if goal is not None:
        register_gym_task(args.env, goal=goal)
    horizon = make_host_env(f"gym:{args.env}").horizon
    for algo in args.algos:
        if algo.startswith("hi-ddpg") and goal is None:
            print(f"{algo} skipped: {args.env} has no goal; declare one with --goal "
                  "INDEX:LOW:HIGH", file=sys.stderr)
            continue
        for seeds in args.seeds:
            rows.append(time_host(algo, seeds, args))
            report(rows[-1])

    skip = "--no-sb3"
    if not args.no_sb3:
        sb3, skip = sb3_rows(args)
        rows += sb3
    base = strongest([r for r in rows if r.name.startswith("SB3 DDPG")])
    if base:
        for r in rows:
            print(f"  {r.name[:48]} x{r.seeds}: {r.rate / base[0].rate:.2f}x SB3 DDPG (wall), "
                  f"{r.cpu_rate / base[1].cpu_rate:.2f}x (per CPU-second), "
                  f"{r.rate / env_row.rate:.3f} of env.step alone")

    text = markdown(rows, base, env_row, skip, args, (load_start, load()), horizon, goal)
    print("\n" + text)
    if args.write:
        write_section(text, SECTION)
        print(f"wrote {DOC}")


if __name__ == "__main__":
    main()
