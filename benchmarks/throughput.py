"""Training throughput of flat DDPG and HI-DDPG against Stable-Baselines3 (run by hand, not a test).

    .venv/bin/python benchmarks/throughput.py                  # prints the table
    .venv/bin/python benchmarks/throughput.py --write          # ... and writes docs/performance.md
    .venv/bin/python benchmarks/throughput.py --episodes 40 --repeats 5 --sb3-steps 5000

What is measured (all on CPU, with the default thread settings of JAX/XLA, NumPy and torch):

* **ours**: :class:`hiddpg.train.Trainer` with the ``paper`` preset on ``PuckTrajectory2``
  (actor, critic and models 300-300, batch 64) and ``agent.learning_starts=0`` (so every step
  learns from the first one), for 1 and 15 seeds. ``init_seeds``, then one chunk of
  ``--episodes`` episodes (compilation), then ``--repeats`` further chunks, each timed to
  ``block_until_ready``. Environment steps = seeds x episodes x 30 (the evaluation episode
  that closes a chunk is not counted, its time is).
* **SB3**: ``stable_baselines3.DDPG`` on ``gym.make("hiddpg/PuckTrajectory2-v0")`` (our
  Gymnasium adapter), CPU torch, ``net_arch`` 300-300 for actor and critic, batch 64,
  ``train_freq=1``, ``gradient_steps=1``, ``learning_starts=0``. A short ``learn`` warms up,
  then ``learn(--sb3-steps)`` is timed. Skipped with a message when SB3 is not installed
  (``pip install torch stable-baselines3``; neither is a dependency of hiddpg).

Steps per second are given per wall-clock second (best of the repeats) and per CPU-second of
this process (``time.process_time``, all threads), which stays meaningful when other jobs share
the cores; CPU/wall > 1 means more than one core was busy.

The fraction of the matrix-multiply peak divides the matmul FLOPs a step executes
(:func:`flops_per_step`, formula below) by NumPy's GFLOP/s on the same matmul shapes
(float32, forward ``(B, in) @ (in, out)``, weight gradient ``(in, B) @ (B, out)``, input
gradient ``(B, out) @ (out, in)``) timed here. The FLOP formula is cross-checked against XLA's
own cost analysis of one jitted update.
"""

from __future__ import annotations

import argparse
import os
import platform
import re
import statistics
import time
from dataclasses import dataclass
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from hiddpg.presets import make_config
from hiddpg.train import Trainer, seed_keys

DOC = Path(__file__).resolve().parents[1] / "docs" / "performance.md"
TASK = "PuckTrajectory2"
HORIZON = 30  # PuckTrajectory2's episode length (checked against the env below)
SECTION = "## Training throughput"

# -- FLOPs per environment step ------------------------------------------------------------------
#
# Only matrix multiplies are counted (elementwise work, Adam and Polyak updates are O(params),
# <3% here). A dense layer ``in -> out`` on a batch of B rows costs
#
#     f(in, out) = 2 B in out                  forward  (B, in) @ (in, out)
#     f(in, out)                               weight gradient  (in, B) @ (B, out)
#     f(in, out)                               input gradient   (B, out) @ (out, in)
#
# For a network N with layers l = 1..L write F(N) = sum_l f(l) (forward), W(N) = F(N) (weight
# gradients), X(N) = sum_l f(l) (input gradients of every layer) and X1(N) = sum_{l>=2} f(l)
# (input gradients a backward pass to the weights needs: the first layer's is skipped).
# Actor A: d_in -> 300 -> 300 -> d_a (tanh); critic C: d_in -> 300, [h, a] -> 300 -> 1 (the
# action enters the second layer, paper §II-D); model M: [s, a] -> 300 -> 300 -> d_s.
#
# One DDPG block update (hiddpg.agents.block.DDPGBlock.update):
#     target  y = r + g Q'(s', mu'(s'))                       F(A) + F(C)
#     critic  value_and_grad of the TD loss                   F(C) + W(C) + X1(C)
#     actor   mu(s) (vjp), dQ/da (vjp), pullback to theta     F(A) + F(C) + X1(C) + W(A) + X1(A)
#   = 2 F(A) + W(A) + X1(A) + 3 F(C) + W(C) + 2 X1(C)  (= 3 F(A) + X1(A) + 4 F(C) + 2 X1(C))
# One HI-DDPG level update (hiddpg.agents.level.Level.update) adds
#     model-based dQ/da: grad_a V(s + dt M(s, a)), V(x) = Q(x, mu(x)), batched over B:
#                                                   F(M) + F(A) + F(C) + X(M) + X(A) + X(C)
#     model   value_and_grad of the MSE                       F(M) + W(M) + X1(M)
# Acting costs F(A) with B = 1 per actor queried.
#
# Flat DDPG, per env step: one block update (batch 64) + the actor on one observation.
# HI-DDPG, per env step: one low-level update, one high-level update and both actors on one
# observation. The high level only *learns* at the end of a segment, but under ``vmap`` its
# ``lax.cond`` is a select, so its update is *executed* every step: that is what is counted
# (``useful`` FLOPs, with the high update only at segment ends, are lower).
# SB3 DDPG, per env step: its critic takes [s, a] at the input and its actor loss
# -Q(s, mu(s)) backpropagates through the critic's weights too (they are computed and discarded):
#     target F(A) + F(C); critic F(C) + W(C) + X1(C); actor F(A) + F(C) + W(C) + X(C) + W(A) + X1(A)


@dataclass(frozen=True)
class Layer:
    d_in: int
    d_out: int


def mlp(d_in: int, hidden: tuple[int, ...], d_out: int) -> list[Layer]:
    sizes = [d_in, *hidden, d_out]
    return [Layer(a, b) for a, b in zip(sizes[:-1], sizes[1:], strict=True)]


def critic_layers(d_obs: int, d_act: int, hidden: tuple[int, ...]) -> list[Layer]:
    """Our critic: the action joins the output of the first hidden layer."""
    sizes = [d_obs, hidden[0] + d_act, *hidden[1:]]
    outs = [*hidden, 1]
    return [Layer(a, b) for a, b in zip(sizes, outs, strict=True)]


#: a matmul (m, k, n): (m, k) @ (k, n), with how often it is executed per env step
Matmul = tuple[int, int, int]


class Count:
    """Accumulates the matmuls of one env step (shapes and multiplicities)."""

    def __init__(self) -> None:
        self.matmuls: dict[Matmul, int] = {}

    def add(self, shape: Matmul, times: int = 1) -> None:
        self.matmuls[shape] = self.matmuls.get(shape, 0) + times

    def fwd(self, net: list[Layer], b: int, times: int = 1) -> None:  # F(N)
        for layer in net:
            self.add((b, layer.d_in, layer.d_out), times)

    def wgrad(self, net: list[Layer], b: int, times: int = 1) -> None:  # W(N)
        for layer in net:
            self.add((layer.d_in, b, layer.d_out), times)

    def xgrad(self, net: list[Layer], b: int, times: int = 1, first: bool = False) -> None:
        """X(N) with ``first``, else X1(N)."""
        for layer in net if first else net[1:]:
            self.add((b, layer.d_out, layer.d_in), times)

    @property
    def flops(self) -> int:
        return sum(2 * m * k * n * t for (m, k, n), t in self.matmuls.items())


def block_update(c: Count, actor: list[Layer], critic: list[Layer], b: int) -> None:
    """One DDPG block update (see the formula above)."""
    c.fwd(actor, b)
    c.fwd(critic, b)  # target
    c.fwd(critic, b)
    c.wgrad(critic, b)
    c.xgrad(critic, b)  # critic step
    c.fwd(actor, b)
    c.fwd(critic, b)
    c.xgrad(critic, b)
    c.wgrad(actor, b)
    c.xgrad(actor, b)  # actor step


def level_update(c: Count, actor: list[Layer], critic: list[Layer], model: list[Layer], b: int,
                 use_model: bool = True, model_gradient: bool = True) -> None:
    """One HI-DDPG level update: the block update, the model-based dQ/da and the model step."""
    block_update(c, actor, critic, b)
    if model_gradient:
        for net in (model, actor, critic):
            c.fwd(net, b)
            c.xgrad(net, b, first=True)
    if use_model:
        c.fwd(model, b)
        c.wgrad(model, b)
        c.xgrad(model, b)


def flops_per_step(algo: str, trainer: Trainer | None = None) -> Count:
    """The matmuls one environment step of ``algo`` executes (``"sb3"``: SB3's DDPG)."""
    c = Count()
    if algo == "sb3":  # PuckTrajectory2: obs 4, action 2, net_arch 300-300, batch 64
        actor, critic, b = mlp(4, (300, 300), 2), mlp(4 + 2, (300, 300), 1), 64
        c.fwd(actor, b)
        c.fwd(critic, b)
        c.fwd(critic, b)
        c.wgrad(critic, b)
        c.xgrad(critic, b)
        c.fwd(actor, b)
        c.fwd(critic, b)
        c.wgrad(critic, b)
        c.xgrad(critic, b, first=True)
        c.wgrad(actor, b)
        c.xgrad(actor, b)
        c.fwd(actor, 1)
        return c
    assert trainer is not None
    env, cfg = trainer.env, trainer.config.agent
    if algo == "ddpg":
        hidden = tuple(cfg.hidden)
        actor = mlp(env.obs_dim, hidden, env.action_dim)
        critic = critic_layers(env.obs_dim, env.action_dim, hidden)
        block_update(c, actor, critic, cfg.batch_size)
        c.fwd(actor, 1)
        return c
    agent = trainer.agent
    for level in (agent.low, agent.high):
        hidden = tuple(level.config.hidden)
        d_in = level.state_dim + level.context_dim
        actor = mlp(d_in, hidden, level.action_dim)
        critic = critic_layers(d_in, level.action_dim, hidden)
        model = mlp(level.state_dim + level.action_dim, hidden, level.state_dim)
        level_update(c, actor, critic, model, level.config.batch_size,
                     use_model=level.use_model, model_gradient=level.model_weight > 0)
        c.fwd(actor, 1)
    return c


def xla_update_flops(algo: str, trainer: Trainer) -> float | None:
    """XLA's cost analysis of one jitted update (all ops, not only matmuls), per env step."""
    try:
        key = jax.random.PRNGKey(0)
        agent = trainer.agent

        def flops(fn, *args) -> float:
            cost = jax.jit(fn).lower(*args).compile().cost_analysis()
            cost = cost[0] if isinstance(cost, list | tuple) else cost
            return float(cost["flops"])

        if algo == "ddpg":
            block, b = agent.block, trainer.config.agent.batch_size
            batch = {"obs": jnp.zeros((b, trainer.env.obs_dim)),
                     "action": jnp.zeros((b, trainer.env.action_dim)),
                     "reward": jnp.zeros((b,)), "next_obs": jnp.zeros((b, trainer.env.obs_dim)),
                     "terminated": jnp.zeros((b,), bool)}
            return flops(block.update, block.init(key), batch)
        return sum(flops(level.update, level.init(key), key) for level in (agent.low, agent.high))
    except Exception as err:  # noqa: BLE001 - a cross-check only
        print(f"  (XLA cost analysis unavailable: {err})")
        return None


# -- NumPy matmul rate ---------------------------------------------------------------------------
def numpy_gflops(matmuls: dict[Matmul, int], min_time: float = 0.3, repeats: int = 5) -> float:
    """GFLOP/s of NumPy (float32) executing exactly ``matmuls`` (each shape its number of
    times) back to back, best of ``repeats`` timings of at least ``min_time`` seconds."""
    rng = np.random.default_rng(0)
    work = []
    for (m, k, n), t in matmuls.items():
        a = rng.standard_normal((m, k), np.float32)
        b = rng.standard_normal((k, n), np.float32)
        work.append((a, b, np.empty((m, n), np.float32), t))
    flops = sum(2 * a.shape[0] * a.shape[1] * b.shape[1] * t for a, b, _, t in work)

    def once() -> None:
        for a, b, out, t in work:
            for _ in range(t):
                np.matmul(a, b, out=out)

    once()
    n = 1
    while True:
        start = time.perf_counter()
        for _ in range(n):
            once()
        if time.perf_counter() - start >= min_time / 4:
            break
        n *= 2
    n = max(1, int(n * min_time / max(time.perf_counter() - start, 1e-9)))
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(n):
            once()
        best = min(best, (time.perf_counter() - start) / n)
    return flops / best / 1e9


def numpy_peak(size: int = 1024) -> float:
    """NumPy float32 GFLOP/s on a large square matmul (the machine's practical peak)."""
    return numpy_gflops({(size, size, size): 4})


# -- timing --------------------------------------------------------------------------------------
@dataclass
class Row:
    name: str
    seeds: int
    steps: int  # env steps per timed run
    walls: list[float]
    cpus: list[float]
    flops: int  # matmul FLOPs per env step
    gflops_same_shapes: float  # NumPy on this row's matmul shapes
    compile_s: float = 0.0
    note: str = ""

    @property
    def best(self) -> int:
        return min(range(len(self.walls)), key=self.walls.__getitem__)

    @property
    def rate(self) -> float:
        return self.steps / self.walls[self.best]

    @property
    def median_rate(self) -> float:
        return self.steps / statistics.median(self.walls)

    @property
    def cpu_rate(self) -> float:
        return self.steps / min(self.cpus)

    @property
    def cores(self) -> float:
        return self.cpus[self.best] / self.walls[self.best]

    @property
    def achieved_gflops(self) -> float:
        return self.rate * self.flops / 1e9

    @property
    def peak_fraction(self) -> float:
        return self.achieved_gflops / self.gflops_same_shapes


def ours_config(algo: str, episodes: int, repeats: int):
    sets = [f"episodes={episodes * (repeats + 1)}", f"eval_every={episodes}",
            f"chunk_episodes={episodes}", "agent.learning_starts=0"]
    if algo != "ddpg":
        sets.append("agent.high_learning_starts=0")
    return make_config(algo, TASK, "paper", sets)


def time_ours(algo: str, seeds: int, episodes: int, repeats: int) -> Row:
    trainer = Trainer(ours_config(algo, episodes, repeats))
    horizon = trainer.env.max_steps(trainer.env_params)
    assert horizon == HORIZON, horizon
    count = flops_per_step(algo, trainer)
    state = trainer.init_seeds(seed_keys(list(range(seeds))))
    jax.block_until_ready(state)
    start = time.perf_counter()
    out = trainer.run_chunk_seeds(state, episodes)  # compiles, then runs the first chunk
    jax.block_until_ready(out)
    compile_s = time.perf_counter() - start
    state = out[0]
    walls, cpus = [], []
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        out = trainer.run_chunk_seeds(state, episodes)
        jax.block_until_ready(out)
        walls.append(time.perf_counter() - start)
        cpus.append(time.process_time() - start_cpu)
        state = out[0]
    steps = int(np.asarray(out[1]["length"]).sum())  # seeds x episodes x 30
    assert steps == seeds * episodes * HORIZON, steps
    name = {"ddpg": "DDPG (ours)", "hi-ddpg": "HI-DDPG (ours)"}.get(algo, algo)
    return Row(name, seeds, steps, walls, cpus, count.flops, numpy_gflops(count.matmuls),
               compile_s=compile_s)


def time_sb3(steps: int, warmup: int, repeats: int) -> Row | None:
    try:
        import gymnasium as gym
        import stable_baselines3
        import torch
        from stable_baselines3 import DDPG
    except ImportError as err:
        print(f"Stable-Baselines3 DDPG skipped: {err.name} is not installed "
              "(.venv/bin/pip install torch stable-baselines3)")
        return None
    import hiddpg  # noqa: F401  (registers the gymnasium ids)

    def make():
        env = gym.make(f"hiddpg/{TASK}-v0")
        model = DDPG(
            "MlpPolicy", env, learning_rate=1e-3, buffer_size=100_000, learning_starts=0,
            batch_size=64, tau=0.001, gamma=0.99, train_freq=1, gradient_steps=1,
            policy_kwargs={"net_arch": {"pi": [300, 300], "qf": [300, 300]}},
            device="cpu", seed=0, verbose=0,
        )
        return model

    model = make()
    model.learn(total_timesteps=warmup)
    walls, cpus = [], []
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        model.learn(total_timesteps=steps, reset_num_timesteps=False)
        walls.append(time.perf_counter() - start)
        cpus.append(time.process_time() - start_cpu)
    count = flops_per_step("sb3")
    note = (f"SB3 {stable_baselines3.__version__}, torch {torch.__version__}, "
            f"{torch.get_num_threads()} torch threads")
    return Row("SB3 DDPG", 1, steps, walls, cpus, count.flops, numpy_gflops(count.matmuls),
               note=note)


# -- report --------------------------------------------------------------------------------------
def load() -> float:
    return os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")


def machine(loads: tuple[float, float]) -> str:
    device = jax.devices()[0]
    cpu = platform.processor() or platform.machine()
    return (f"{device.platform.upper()}, {os.cpu_count()} CPU cores ({cpu}), jax "
            f"{jax.__version__}, numpy {np.__version__}; 1-minute load average "
            f"{loads[0]:.1f} at the start and {loads[1]:.1f} at the end of the run")


def markdown(rows: list[Row], sb3: Row | None, peak: float, args: argparse.Namespace,
             loads: tuple[float, float], xla: dict[str, tuple[int, float | None]]) -> str:
    head = ("| run | seeds | env steps/s (wall, best) | median | per CPU-second | CPU/wall | "
            "vs SB3 (wall) | vs SB3 (CPU) | matmul GFLOP/step | GFLOP/s | % of NumPy, same "
            "shapes | % of NumPy 1024² |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
            "---:|---:|\n")
    body = ""
    for r in rows + ([sb3] if sb3 else []):
        ratio = f"{r.rate / sb3.rate:.1f}×" if sb3 else "n/a"
        cpu_ratio = f"{r.cpu_rate / sb3.cpu_rate:.1f}×" if sb3 else "n/a"
        body += (f"| {r.name} | {r.seeds} | {r.rate:,.0f} | {r.median_rate:,.0f} | "
                 f"{r.cpu_rate:,.0f} | {r.cores:.2f} | {ratio} | {cpu_ratio} | "
                 f"{r.flops / 1e9:.3f} | {r.achieved_gflops:.1f} | "
                 f"{100 * r.peak_fraction:.1f}% (of {r.gflops_same_shapes:.0f}) | "
                 f"{100 * r.achieved_gflops / peak:.1f}% |\n")
    checks = "; ".join(
        f"{algo}: {ours / 1e9:.3f} GFLOP formula vs {x / 1e9:.3f} XLA"
        for algo, (ours, x) in xla.items() if x is not None)
    sb3_note = sb3.note if sb3 else "SB3 not installed: skipped"
    cmd = (f".venv/bin/python benchmarks/throughput.py --episodes {args.episodes} "
           f"--repeats {args.repeats} --sb3-steps {args.sb3_steps} --write")
    return (
        f"{SECTION}\n\n"
        f"Environment steps per second while training on {TASK} with updates from the first "
        "step (paper preset: actor, critic and models 300-300, batch 64, "
        "`agent.learning_starts=0`), measured by `benchmarks/throughput.py` on "
        f"{machine(loads)}, {time.strftime('%Y-%m-%d')}. Default thread settings everywhere "
        f"(XLA_FLAGS={os.environ.get('XLA_FLAGS', '') or 'unset'}; {sb3_note}).\n\n"
        f"Ours: `Trainer.run_chunk_seeds` on a chunk of {args.episodes} episodes per seed "
        "(+1 evaluation episode, timed but not counted), after a first chunk that compiles; "
        f"best and median of {args.repeats} chunks; steps = seeds × episodes × 30. SB3: "
        "`DDPG('MlpPolicy', gym.make('hiddpg/PuckTrajectory2-v0'))`, net_arch 300-300, batch "
        "64, train_freq 1, gradient_steps 1, learning_starts 0, CPU torch; "
        f"`learn({args.sb3_steps})` after a warm-up. Per CPU-second divides by the CPU time of "
        "the process (all threads); CPU/wall is the mean number of busy cores. Matmul FLOPs "
        "per step are counted by the formula in the script (HI-DDPG: the high level's update "
        "is executed every step under `vmap`, and counted so); % of NumPy divides the "
        "achieved rate by NumPy's float32 GFLOP/s on the same matmul shapes, and on a "
        f"1024×1024 matmul ({peak:.0f} GFLOP/s). Formula vs XLA's cost analysis of one update "
        f"(all ops): {checks or 'n/a'}.\n\n"
        + head + body + f"\nReproduce: `{cmd}`\n"
    )


def write_section(text: str, path: Path = DOC) -> None:
    """Replace (or append) the ``## Training throughput`` section (up to the next ``## ``)."""
    old = path.read_text() if path.exists() else "# Performance\n\n"
    pattern = re.compile(r"^## Training throughput\n.*?(?=^## |\Z)", re.S | re.M)
    new = pattern.sub(lambda _: text + "\n", old) if pattern.search(old) else (
        old.rstrip("\n") + "\n\n" + text)
    path.write_text(new)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=20, help="episodes per seed per chunk")
    parser.add_argument("--repeats", type=int, default=3, help="timed chunks / SB3 runs")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 15])
    parser.add_argument("--algos", nargs="+", default=["ddpg", "hi-ddpg"])
    parser.add_argument("--sb3-steps", type=int, default=2000)
    parser.add_argument("--sb3-warmup", type=int, default=200)
    parser.add_argument("--no-sb3", action="store_true")
    parser.add_argument("--write", action="store_true", help=f"write the section to {DOC}")
    args = parser.parse_args()

    load_start = load()
    print(f"load average {load_start:.2f}; XLA devices {jax.devices()}; "
          f"XLA_FLAGS={os.environ.get('XLA_FLAGS', '') or 'unset'}", flush=True)
    peak = numpy_peak()
    print(f"NumPy float32 1024x1024 matmul: {peak:.1f} GFLOP/s", flush=True)

    rows, xla = [], {}
    for algo in args.algos:
        trainer = Trainer(ours_config(algo, args.episodes, args.repeats))
        count = flops_per_step(algo, trainer)
        per_update = xla_update_flops(algo, trainer)
        acting = sum(2 * m * k * n * t for (m, k, n), t in count.matmuls.items() if m == 1)
        xla[algo] = (count.flops - acting, per_update)
        for seeds in args.seeds:
            row = time_ours(algo, seeds, args.episodes, args.repeats)
            rows.append(row)
            print(f"{row.name:16s} seeds {seeds:2d}: {row.rate:8,.0f} steps/s (median "
                  f"{row.median_rate:,.0f}), {row.cpu_rate:8,.0f} per CPU-s, CPU/wall "
                  f"{row.cores:.2f}, compile+1st chunk {row.compile_s:.1f} s, "
                  f"{row.achieved_gflops:.1f} GFLOP/s = {100 * row.peak_fraction:.1f}% of "
                  f"NumPy on the same shapes ({row.gflops_same_shapes:.1f})", flush=True)

    sb3 = None if args.no_sb3 else time_sb3(args.sb3_steps, args.sb3_warmup, args.repeats)
    if sb3:
        print(f"{sb3.name:16s} seeds  1: {sb3.rate:8,.0f} steps/s (median "
              f"{sb3.median_rate:,.0f}), {sb3.cpu_rate:8,.0f} per CPU-s, CPU/wall "
              f"{sb3.cores:.2f}, {sb3.achieved_gflops:.1f} GFLOP/s = "
              f"{100 * sb3.peak_fraction:.1f}% of NumPy on the same shapes; {sb3.note}")
        for r in rows:
            print(f"  {r.name} x{r.seeds}: {r.rate / sb3.rate:.1f}x SB3 (wall), "
                  f"{r.cpu_rate / sb3.cpu_rate:.1f}x (CPU)")
    busy = [r for r in rows if r.cores > 1.2]
    print("XLA CPU used more than one core in: "
          + (", ".join(f"{r.name} x{r.seeds} ({r.cores:.2f})" for r in busy) or "no run"))

    text = markdown(rows, sb3, peak, args, (load_start, load()), xla)
    print("\n" + text)
    if args.write:
        write_section(text)
        print(f"wrote {DOC}")


if __name__ == "__main__":
    main()
