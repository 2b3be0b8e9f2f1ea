"""Throughput of the environments (run by hand, not a test).

    .venv/bin/python benchmarks/envs.py                 # all tasks, writes docs/performance.md
    .venv/bin/python benchmarks/envs.py --tasks ArmReach --envs 1 4096 --no-write

For every task: control steps per second of the jitted functional core, for one environment and
vmapped over a batch, each a ``lax.scan`` of steps inside one ``jit`` (timed after compilation,
``block_until_ready``, best of ``--repeats``); and of the Gymnasium adapter (one Python call per
step). Actions are uniform random, drawn beforehand (a table of 16 per environment, cycled);
finished episodes restart from their initial state inside the scan (auto-reset), as in training.
The table goes to the "Environments" section of ``docs/performance.md``.
"""

from __future__ import annotations

import argparse
import os
import platform
import re
import time
from pathlib import Path

import jax
import jax.numpy as jnp

from hiddpg.envs import TASKS, make

DOC = Path(__file__).resolve().parents[1] / "docs" / "performance.md"
ACTION_TABLE = 16


def core_rollout(core, params, n_envs: int, n_steps: int):
    """A jitted function running ``n_steps`` auto-resetting steps of ``n_envs`` environments."""

    def run(key):
        reset_key, action_key, step_key = jax.random.split(key, 3)
        _, state0 = jax.vmap(core.reset, (0, None))(jax.random.split(reset_key, n_envs), params)
        table = jax.random.uniform(action_key, (ACTION_TABLE, n_envs, core.action_dim),
                                   minval=core.action_low, maxval=core.action_high)
        step = jax.vmap(core.step, (0, 0, 0, None))

        def body(carry, t):
            state, total = carry
            keys = jax.random.split(jax.random.fold_in(step_key, t), n_envs)
            result = step(keys, state, table[t % ACTION_TABLE], params)
            done = result.terminated | result.truncated
            state = jax.tree.map(
                lambda s0, s: jnp.where(done.reshape(done.shape + (1,) * (s.ndim - 1)), s0, s),
                state0, result.state)
            return (state, total + result.reward.sum()), None

        (state, total), _ = jax.lax.scan(body, (state0, jnp.zeros(())), jnp.arange(n_steps))
        return total

    return jax.jit(run)


def time_core(task: str, n_envs: int, n_steps: int, repeats: int) -> tuple[float, float]:
    """Steps per wall-clock second and per CPU-second of this process (the second is robust
    to other processes competing for the cores), best of ``repeats``."""
    core, params = make(task)
    run = core_rollout(core, params, n_envs, n_steps)
    key = jax.random.PRNGKey(0)
    run(key).block_until_ready()  # compile
    wall = cpu = float("inf")
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        run(key).block_until_ready()
        wall = min(wall, time.perf_counter() - start)
        cpu = min(cpu, time.process_time() - start_cpu)
    return n_envs * n_steps / wall, n_envs * n_steps / cpu


def time_gym(task: str, n_steps: int, repeats: int) -> float:
    import gymnasium as gym

    import hiddpg  # noqa: F401  (registers the ids)

    env = gym.make(f"hiddpg/{task}-v0")
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(ACTION_TABLE)]
    env.reset(seed=0)
    for i in range(20):  # compile and warm up
        env.step(actions[i % ACTION_TABLE])
    best = float("inf")
    for _ in range(repeats):
        env.reset(seed=0)
        start = time.perf_counter()
        for i in range(n_steps):
            _, _, terminated, truncated, _ = env.step(actions[i % ACTION_TABLE])
            if terminated or truncated:
                env.reset()
        best = min(best, time.perf_counter() - start)
    return n_steps / best


def machine() -> str:
    device = jax.devices()[0]
    cpu = platform.processor() or platform.machine()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return (f"{device.platform.upper()} ({device.device_kind}), {os.cpu_count()} CPU cores "
            f"({cpu}, load average {load:.1f} at the end of the run), jax {jax.__version__}")


def markdown(rows: list[tuple[str, dict[int, tuple[float, float]], float]], batches: list[int],
             steps: dict[int, int]) -> str:
    def envs(n: int) -> str:
        return f"{n} env{'s' * (n > 1)}"

    head = "| task | " + " | ".join(f"core, {envs(n)}" for n in batches)
    head += f" | core, {envs(batches[-1])}, per CPU-second | Gymnasium adapter |\n"
    head += "|---|" + "---:|" * (len(batches) + 2) + "\n"
    body = "".join(
        f"| {task} | " + " | ".join(f"{r[n][0]:,.0f}" for n in batches)
        + f" | {r[batches[-1]][1]:,.0f} | {g:,.0f} |\n"
        for task, r, g in rows
    )
    scans = ", ".join(f"{steps[n]:,} steps for {envs(n)}" for n in batches)
    return (
        "## Environments\n\n"
        "Control steps per second (higher is better), measured by `benchmarks/envs.py` on "
        f"{machine()}, {time.strftime('%Y-%m-%d')}.\n"
        f"Core: one jitted `lax.scan` ({scans}) of `vmap(step)` with random actions and "
        "auto-reset, timed after compilation; the per-CPU-second column divides by the CPU "
        "time of the benchmark process instead of wall time, which stays meaningful when "
        "other processes share the cores. Gymnasium adapter: `gym.make(id)`, `env.step` in "
        "a Python loop with resets, one environment. Best of the repeats.\n\n" + head + body
    )


def write_section(text: str, path: Path = DOC) -> None:
    """Replace (or append) the ``## Environments`` section of ``path``."""
    old = path.read_text() if path.exists() else "# Performance\n\n"
    pattern = re.compile(r"^## Environments\n.*?(?=^## |\Z)", re.S | re.M)
    new = pattern.sub(lambda _: text + "\n", old) if pattern.search(old) else (
        old.rstrip("\n") + "\n\n" + text)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(new)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", nargs="+", default=list(TASKS))
    parser.add_argument("--envs", nargs="+", type=int, default=[1, 1024])
    parser.add_argument("--steps", type=int, default=1_000_000,
                        help="total control steps per timed core run (split over the envs)")
    parser.add_argument("--gym-steps", type=int, default=3000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    # one env runs fewer steps: it is slow per step and the scan is sequential
    steps = {n: max(100, args.steps // n) if n > 1 else args.steps // 50 for n in args.envs}
    rows = []
    for task in args.tasks:
        rates = {n: time_core(task, n, steps[n], args.repeats) for n in args.envs}
        gym_rate = time_gym(task, args.gym_steps, args.repeats)
        rows.append((task, rates, gym_rate))
        print(task, {n: f"{r[0]:,.0f} ({r[1]:,.0f}/cpu-s)" for n, r in rates.items()},
              f"gym {gym_rate:,.0f}", flush=True)
    text = markdown(rows, args.envs, steps)
    print("\n" + text)
    if not args.no_write:
        write_section(text)
        print(f"wrote {DOC}")


if __name__ == "__main__":
    main()
