"""What the throughput benchmarks share (``throughput.py``: our JAX engine, ``host_throughput.py``:
the host loop on Gymnasium environments): the benchmark configs (an update at every step from the
first one), timing chunks of training and Stable-Baselines3's ``learn``, the result rows, fresh
worker processes and writing a section of ``docs/performance.md``.

Nothing here starts JAX's backends: the scripts ask for their CPU devices first
(:func:`hiddpg.devices.request_cpu_devices`), then import this module.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import os
import platform
import re
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

DOC = Path(__file__).resolve().parents[1] / "docs" / "performance.md"


# -- rows ----------------------------------------------------------------------------------------
def load() -> float:
    """The 1-minute load average (nan where the OS has none)."""
    return os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")


def cpu_name() -> str:
    """The CPU's model name (``/proc/cpuinfo``), else what :mod:`platform` says."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


@dataclass
class Row:
    name: str
    seeds: int
    steps: int  # env steps per timed run
    walls: list[float]
    cpus: list[float]
    flops: int = 0  # matmul FLOPs per env step (throughput.py)
    core_gflops: float = float("nan")  # NumPy, 1 thread, this row's matmul shapes
    machine_gflops: float = float("nan")  # NumPy, whole machine, this row's matmul shapes
    compile_s: float = 0.0
    note: str = ""
    load: float = dataclasses.field(default_factory=lambda: load())  # when the row ended

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
    def gflops(self) -> float:
        return self.rate * self.flops / 1e9


def strongest(rows: list[Row]) -> tuple[Row, Row] | None:
    """The baseline rows the ratios divide by: the most steps per wall-clock second and the
    most per CPU-second (None without rows)."""
    if not rows:
        return None
    return max(rows, key=lambda r: r.rate), max(rows, key=lambda r: r.cpu_rate)


# -- timing --------------------------------------------------------------------------------------
def timed(run: Any, repeats: int) -> tuple[list[float], list[float]]:
    """Wall-clock and CPU seconds (``time.process_time``: this process, all its threads) of
    ``repeats`` calls of ``run()``, which returns once its work is done."""
    walls, cpus = [], []
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        run()
        walls.append(time.perf_counter() - start)
        cpus.append(time.process_time() - start_cpu)
    return walls, cpus


def time_chunks(trainer: Any, seeds: int, episodes: int, repeats: int
                ) -> tuple[list[float], list[float], float, tuple]:
    """A trainer's (``Trainer`` or ``HostTrainer``) chunks of ``episodes`` episodes for seeds
    ``0..seeds-1``: ``init_seeds``, a first chunk (compilation) and ``repeats`` chunks timed to
    ``block_until_ready``. Returns the timed chunks' wall and CPU seconds, the first chunk's
    seconds and the last chunk's ``(state, train metrics, eval metrics)``."""
    import jax

    from hiddpg.train import seed_keys

    state = trainer.init_seeds(seed_keys(list(range(seeds))))
    jax.block_until_ready(state)
    start = time.perf_counter()
    out = trainer.run_chunk_seeds(state, episodes)  # compiles, then runs the first chunk
    jax.block_until_ready(out)
    compile_s = time.perf_counter() - start
    last = [out]

    def chunk() -> None:
        last[0] = jax.block_until_ready(trainer.run_chunk_seeds(last[0][0], episodes))

    walls, cpus = timed(chunk, repeats)
    return walls, cpus, compile_s, last[0]


# -- the benchmark configs -----------------------------------------------------------------------
#: benchmark variants ``ALGO@NAME``: the preset plus these overrides
VARIANTS = {"every-step": ["agent.eager_high.every_step=true"]}


def bench_config(algo: str, task: str, episodes: int, repeats: int, sets: tuple = ()):
    """The ``paper`` preset of ``algo`` (``ALGO@VARIANT``: plus :data:`VARIANTS`) on ``task``
    with ``sets`` and every agent learning from the first environment step
    (``learning_starts=0``, HI-DDPG's ``high_learning_starts=0``), run in chunks of
    ``episodes`` episodes, one first chunk and ``repeats`` timed ones."""
    from hiddpg.presets import make_config

    algo, _, variant = algo.partition("@")
    sets = [f"episodes={episodes * (repeats + 1)}", f"eval_every={episodes}",
            f"chunk_episodes={episodes}", *VARIANTS.get(variant, []), *sets]
    if algo == "h-ddpg":
        sets.append("agent.skill.learning_starts=0")
    else:
        sets.append("agent.learning_starts=0")
    if algo in ("hi-ddpg", "hi-ddpg-wo-model"):
        sets.append("agent.high_learning_starts=0")
    return make_config(algo, task, "paper", sets)


def every_step(agent: Any) -> bool:
    """Whether HI-DDPG's high level updates at every step (``EagerHighLevel``)."""
    return agent.eager_high is not None and agent.eager_high.every_step


def high_updates_per_step(config: Any, train: dict, steps: int) -> float:
    """HI-DDPG's high-level updates per environment step in the training metrics ``train``
    (one per segment under Alg. 1: the goal switches plus one per episode); 1 otherwise."""
    if not config.algo.startswith("hi-ddpg") or every_step(config.agent):
        return 1.0
    import numpy as np

    return float((np.asarray(train["switches"]) + 1).sum()) / steps


# -- worker processes, Stable-Baselines3 ---------------------------------------------------------
def worker(script: str, args: list[str], env: dict | None = None) -> dict:
    """Run ``script --worker ARGS`` in a fresh process; its last JSON line."""
    proc = subprocess.run([sys.executable, script, "--worker", *args], env=env,
                          capture_output=True, text=True, check=False)
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("{")]
    if proc.returncode or not lines:
        raise RuntimeError(f"worker {args} failed:\n{proc.stdout}\n{proc.stderr}")
    return json.loads(lines[-1])


def sb3_learn(algo: str, env_id: str, hidden: list[int], batch: int, threads: int, steps: int,
              warmup: int, repeats: int) -> dict:
    """Time Stable-Baselines3's ``algo`` (``DDPG``, ``TD3``) on ``gym.make(env_id)`` in this
    process: ``net_arch`` ``hidden`` for actor and critic, batch ``batch``, ``train_freq=1``,
    ``gradient_steps=1``, ``learning_starts=0``, CPU torch with ``threads`` threads (0:
    torch's default); ``learn(warmup)``, then ``repeats`` timed ``learn(steps)``. A dict with
    ``skip`` says why nothing was timed."""
    try:
        import gymnasium as gym
        import stable_baselines3
        import torch
    except ImportError as err:
        return {"skip": f"{err.name} is not installed"}
    import hiddpg  # noqa: F401  (registers the gymnasium ids)

    if threads:
        torch.set_num_threads(threads)
    model = getattr(stable_baselines3, algo)(
        "MlpPolicy", gym.make(env_id), learning_rate=1e-3, buffer_size=100_000,
        learning_starts=0, batch_size=batch, tau=0.001, gamma=0.99, train_freq=1,
        gradient_steps=1, policy_kwargs={"net_arch": {"pi": list(hidden), "qf": list(hidden)}},
        device="cpu", seed=0, verbose=0,
    )
    model.learn(total_timesteps=warmup)
    walls, cpus = timed(
        lambda: model.learn(total_timesteps=steps, reset_num_timesteps=False), repeats)
    return {"walls": walls, "cpus": cpus, "threads": torch.get_num_threads(),
            "versions": f"SB3 {stable_baselines3.__version__}, torch {torch.__version__}"}


def time_sb3(script: str, args: list[str], algo: str, threads: int | None, steps: int,
             flops: int = 0) -> Row | str:
    """SB3 ``algo`` in a fresh process (torch's threads then compete with no JAX threads),
    ``script --worker ARGS`` timing ``learn(steps)``; ``threads=None`` is torch's default. A
    string says why it was skipped."""
    if importlib.util.find_spec("stable_baselines3") is None:
        return "stable_baselines3 is not installed"
    out = worker(script, args)
    if "skip" in out:
        return out["skip"]
    label = f"{out['threads']} torch thread{'s' * (out['threads'] > 1)}"
    label += " (default)" if threads is None else ""
    return Row(f"SB3 {algo}, {label}", 1, steps, out["walls"], out["cpus"], flops,
               note=out["versions"])


# -- docs/performance.md -------------------------------------------------------------------------
def write_section(text: str, heading: str, path: Path = DOC) -> None:
    """Replace (or append) the section ``heading`` (a ``## `` line, up to the next ``## ``)."""
    old = path.read_text() if path.exists() else "# Performance\n\n"
    pattern = re.compile(rf"^{re.escape(heading)}\n.*?(?=^## |\Z)", re.S | re.M)
    new = pattern.sub(lambda _: text + "\n", old) if pattern.search(old) else (
        old.rstrip("\n") + "\n\n" + text)
    path.write_text(new)
