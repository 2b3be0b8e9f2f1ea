"""HI-DDPG, DDPG and h-DDPG against Stable-Baselines3's DDPG and TD3 on a Gymnasium task, with
numbers: learning curves over seeds, a table and a GIF (run by hand; hours at full budget).

    .venv/bin/python benchmarks/gym_demo.py --env Reacher-v5
    .venv-myo/bin/python benchmarks/gym_demo.py --env myoElbowPose1D6MRandom-v0
    .venv/bin/python benchmarks/gym_demo.py --env Reacher-v5 --estimate-only
    .venv/bin/python benchmarks/gym_demo.py --env Reacher-v5 --tiny --episodes 8 \\
        --eval-every 4 --eval-episodes 2 --seeds 0-1 --out /tmp/demo   # a smoke run

MyoSuite needs its own virtualenv (scripts/myosuite_venv.sh). The goals and skills are the
shipped ones (:mod:`hiddpg.host.catalog`). Every method trains for the same number of
environment steps per seed (``--episodes`` x the horizon: neither task ends an episode early)
and is evaluated the same way: before training and after every ``--eval-every`` episodes'
steps, ``--eval-episodes`` noise-free episodes from the same Gymnasium reset seeds for every
method and seed (those of the episode keys ``PRNGKey(10000 + i)``, as our host loop draws
them). Ours: ``--preset paper`` (the presets' generic values for a Gymnasium task), the seeds
of one invocation trained together in one run directory (``OUT/runs/METHOD-seeds-0-4``,
resumed from its checkpoint); ``--seeds 0-1`` then ``--seeds 2-4`` trains a method's seeds in
two parts, each a record of its own, so a method too long for one sitting is trained part by
part and the curves and table merge the finished parts.
SB3: ``DDPG`` and ``TD3`` with our networks (``--hidden``), batch (64), replay (100,000),
random steps before learning (DDPG's ``learning_starts``), discount (0.99) and Gaussian action
noise of 0.1 of the half range (our OU noise's scale); their own learning rates (1e-3) and
tau (0.005); one torch thread (``SB3_THREADS``: two seed ranges then run side by side on two
cores, and the per-CPU-second rate counts no idle spinning of a second thread); one seed after
another, each seed's record written when it finishes.

Written under ``OUT`` (default ``results/gym-demo/ENV``): ``records/METHOD/seeds-0-4.json``
(ours; SB3's ``records/METHOD/seed0.json``: the evaluation curve of every seed, the config and
the versions), ``rates.json`` (the measured
steps per second), ``curves.png`` (mean +- std over seeds), ``table.md`` (final return per
method, mean +- std over seeds, and the Welch 95% interval of each method's difference to SB3
TD3) and ``hi-ddpg.gif`` (``hiddpg eval --gif`` of our HI-DDPG run, ``MUJOCO_GL=egl``).
Rerunning skips what is done.

Budgets: Reacher-v5 2,000 episodes of 50 steps (100,000 steps per seed), evaluated every
5,000 steps; the elbow 1,000 episodes of 100 steps (100,000). The paper preset's own budget
for a Gymnasium task, 3,000 episodes (150,000 Reacher steps), would take half as long again;
100,000 steps x 5 seeds x 5 methods is the smallest budget worth a curve, and already many
hours on two cores: ``--estimate-only`` prints them from measured rates (steps per CPU-second,
cached in ``rates.json``); ``--episodes`` halves it for a quicker look.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco
from hiddpg.devices import request_cpu_devices  # noqa: E402

request_cpu_devices()  # as the hiddpg command does

import jax  # noqa: E402
import numpy as np  # noqa: E402
from _demo_summary import OURS, read, summarize  # noqa: E402

from hiddpg.host.catalog import ELBOW_ENV, ELBOW_ID  # noqa: E402

ENVS = {"Reacher-v5": ("Reacher-v5", 2000, 100), ELBOW_ID: (ELBOW_ENV, 1000, 50)}
SB3 = ("sb3-ddpg", "sb3-td3")
SB3_THREADS = 1  # torch threads of an SB3 run (see above)
EVAL_KEY, BATCH, BUFFER = 10_000, 64, 100_000


def versions() -> dict:
    out = {"python": sys.version.split()[0]}
    for p in ("hiddpg", "jax", "gymnasium", "mujoco", "myosuite", "stable-baselines3", "torch"):
        try:
            out[p] = importlib.metadata.version(p)
        except importlib.metadata.PackageNotFoundError:
            pass
    return out


def eval_seeds(n: int) -> tuple[list, list[int]]:
    """The evaluation episodes' keys and their Gymnasium reset seeds."""
    from hiddpg.host.gif import reset_seed

    keys = [jax.random.PRNGKey(EVAL_KEY + i) for i in range(n)]
    return keys, [reset_seed(k) for k in keys]


def write(path: Path, data: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=1) + "\n")
    tmp.replace(path)


def part_name(seeds: list[int]) -> str:
    """The name of our run and record of these seeds: ``seeds-0-4``, ``seeds-0-1_5``."""
    from hiddpg.runner import seed_ranges

    return "seeds-" + "_".join(seed_ranges(seeds))


def check_part(out: Path, method: str, seeds: list[int]) -> None:
    """Exit with a message if another record of ``method`` holds one of ``seeds``."""
    mine = out / "records" / method / f"{part_name(seeds)}.json"
    for f in sorted((out / "records" / method).glob("seed*.json")):
        rec = read(f) or {}
        held = set(rec.get("seeds", [rec.get("seed")]))
        if f != mine and held & set(seeds):
            raise SystemExit(f"--seeds {','.join(map(str, seeds))}: {method} already has "
                             f"seeds {sorted(held & set(seeds))} in {f}; choose others")


def our_sets(algo: str, a: argparse.Namespace) -> list[str]:
    h = "[" + ",".join(map(str, a.hidden)) + "]"
    levels = {"ddpg": [""], "hi-ddpg": ["high.", "low."], "h-ddpg": ["skill.", "meta."]}[algo]
    sets = [f"episodes={a.episodes}", f"eval_every={a.eval_every}",
            f"chunk_episodes={a.eval_every}", *(f"agent.{lv}hidden={h}" for lv in levels)]
    if a.tiny:
        sets += [f"agent.{lv}batch_size=16" for lv in levels]
        sets += {"ddpg": ["agent.learning_starts=50"], "h-ddpg": ["agent.skill.learning_starts=50"],
                 "hi-ddpg": ["agent.learning_starts=50", "agent.high_learning_starts=4",
                             "agent.high.batch_size=4"]}[algo]
    return sets + list(a.set)


def sb3_params(a: argparse.Namespace, task: str) -> dict:
    from hiddpg.presets import make_config

    starts = make_config("ddpg", task, "paper", our_sets("ddpg", a)).agent.learning_starts
    return {"buffer_size": BUFFER, "batch_size": 16 if a.tiny else BATCH, "gamma": 0.99,
            "learning_starts": starts, "train_freq": 1, "gradient_steps": 1, "noise": 0.1,
            "net_arch": list(a.hidden)}


# -- ours ------------------------------------------------------------------------------------
def run_ours(algo: str, a: argparse.Namespace, out: Path, horizon: int) -> None:
    from hiddpg.presets import make_config
    from hiddpg.reporter import ConsoleReporter
    from hiddpg.runner import open_for_resume, prepare_new, train_run
    from hiddpg.runs import make_trainer

    check_part(out, algo, a.seeds)
    name = part_name(a.seeds)
    rec_path, path = out / "records" / algo / f"{name}.json", out / "runs" / f"{algo}-{name}"
    config = make_config(algo, "gym:" + ENVS[a.env][0], "paper", our_sets(algo, a))
    if path.is_dir():
        run, trainer, done = open_for_resume(path, a.episodes)  # may extend the budget
    else:
        run, trainer, done = prepare_new(config, a.seeds, path), make_trainer(config), 0
    rec = read(rec_path) or {"method": algo, "env": a.env, "seeds": a.seeds, "evals": []}
    rec.update(run=str(path), config=json.loads((path / "config.json").read_text()),
               versions=versions(), eval_reset_seeds=eval_seeds(a.eval_episodes)[1])
    rec["evals"] = [e for e in rec["evals"] if e["steps"] <= done * horizon]
    keys = eval_seeds(a.eval_episodes)[0]

    def evaluate(state, episodes: int) -> None:
        rows = []
        for key in keys:  # every seed's environment resets from the same seed
            metrics, _ = trainer.evaluate_seeds(state, jax.numpy.stack([key] * len(a.seeds)))
            rows.append(np.asarray(metrics["env_return"], float))
        rec["evals"].append({"steps": episodes * horizon,
                             "returns": np.stack(rows, 1).tolist()})  # (seed, episode)
        write(rec_path, rec)

    if not rec["evals"] or rec["evals"][-1]["steps"] < done * horizon:
        evaluate(run.load_checkpoint(trainer)[0], done)  # before training, or a lost one
    if done < config.episodes:
        result = train_run(run, trainer, reporter=ConsoleReporter(),
                           on_chunk=lambda r, n: evaluate(r.load_checkpoint(trainer)[0], n))
        if result.status != "finished":
            raise SystemExit(f"{algo}: {result.status} {result.error or ''}")
    else:
        run.close()
    rec["finished"] = True
    write(rec_path, rec)


# -- Stable-Baselines3 -------------------------------------------------------------------------
def run_sb3(method: str, a: argparse.Namespace, out: Path, horizon: int) -> None:
    import gymnasium as gym
    import stable_baselines3 as sb3
    import torch
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.noise import NormalActionNoise

    torch.set_num_threads(SB3_THREADS)

    p, env_id = sb3_params(a, "gym:" + ENVS[a.env][0]), ENVS[a.env][0]
    reset_seeds, every = eval_seeds(a.eval_episodes)[1], a.eval_every * horizon
    evaluator = gym.make(env_id)

    def evaluate(model) -> list[float]:
        returns = []
        for s in reset_seeds:
            obs, _ = evaluator.reset(seed=s)
            total, done = 0.0, False
            while not done:
                action, _ = model.predict(obs, deterministic=True)
                obs, reward, term, trunc, _ = evaluator.step(action)
                total, done = total + float(reward), term or trunc
            returns.append(total)
        return returns

    class Every(BaseCallback):
        def _on_step(self) -> bool:
            if self.num_timesteps % every == 0:
                evals.append({"steps": self.num_timesteps, "returns": evaluate(self.model)})
            return True

    check_part(out, method, a.seeds)
    for seed in a.seeds:
        path = out / "records" / method / f"seed{seed}.json"
        if path.is_file():
            continue
        env = gym.make(env_id)
        n = env.action_space.shape[0]
        half = (env.action_space.high - env.action_space.low) / 2
        model = getattr(sb3, method[4:].upper())(
            "MlpPolicy", env, buffer_size=p["buffer_size"], batch_size=p["batch_size"],
            gamma=p["gamma"], learning_starts=p["learning_starts"], train_freq=1,
            gradient_steps=1, action_noise=NormalActionNoise(np.zeros(n), p["noise"] * half),
            policy_kwargs={"net_arch": p["net_arch"]}, device="cpu", seed=seed, verbose=0)
        evals = [{"steps": 0, "returns": evaluate(model)}]
        start = time.perf_counter()
        model.learn(total_timesteps=a.episodes * horizon, callback=Every())
        write(path, {"method": method, "env": a.env, "seed": seed, "evals": evals, "params": p,
                     "torch_threads": torch.get_num_threads(),
                     "wall_s": time.perf_counter() - start, "versions": versions(),
                     "eval_reset_seeds": reset_seeds})
        print(f"{method} seed {seed}: {evals[-1]['returns']}", flush=True)


# -- rates, summary ----------------------------------------------------------------------------
def probe(method: str, a: argparse.Namespace, horizon: int) -> float:
    """Steps per CPU-second (this process, all threads) of ``method`` while learning (all
    seeds), after compilation: unlike wall-clock rates, meaningful on a shared machine."""
    n, task = 2 if a.tiny else 4, "gym:" + ENVS[a.env][0]
    if method in SB3:
        import gymnasium as gym
        import stable_baselines3 as sb3
        import torch

        torch.set_num_threads(SB3_THREADS)
        p = sb3_params(a, task)
        model = getattr(sb3, method[4:].upper())(
            "MlpPolicy", gym.make(ENVS[a.env][0]), batch_size=p["batch_size"],
            learning_starts=0, policy_kwargs={"net_arch": p["net_arch"]}, device="cpu")
        model.learn(2 * horizon)
        start = time.process_time()
        model.learn(n * horizon, reset_num_timesteps=False)
        return n * horizon / (time.process_time() - start)
    from hiddpg.host import HostTrainer
    from hiddpg.presets import make_config
    from hiddpg.train import seed_keys

    starts = {"ddpg": ["agent.learning_starts=0"], "h-ddpg": ["agent.skill.learning_starts=0"],
              "hi-ddpg": ["agent.learning_starts=0", "agent.high_learning_starts=0",
                          "agent.pretrain_episodes=0"]}[method]
    sets = [*our_sets(method, a), "eval_every=1", "chunk_episodes=1", *starts]
    trainer = HostTrainer(make_config(method, task, "paper", sets))
    state = trainer.init_seeds(seed_keys(a.seeds))
    state = trainer.run_chunk_seeds(state, 1)[0]  # compiles
    start = time.process_time()
    for _ in range(n // 2):
        state = jax.block_until_ready(trainer.run_chunk_seeds(state, 1)[0])
    trainer.close()
    return (n // 2) * horizon * len(a.seeds) / (time.process_time() - start)


def main(argv: list[str] | None = None) -> int:
    from hiddpg.runner import parse_seeds

    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--env", choices=list(ENVS), default="Reacher-v5")
    p.add_argument("--out", type=Path, default=None)
    p.add_argument("--seeds", type=parse_seeds, default=parse_seeds("0-4"))
    p.add_argument("--methods", nargs="+", choices=[*OURS, *SB3], default=[*OURS, *SB3])
    p.add_argument("--episodes", type=int, default=None, help="per seed (default: see above)")
    p.add_argument("--eval-every", type=int, default=None, help="episodes between evaluations")
    p.add_argument("--eval-episodes", type=int, default=10)
    p.add_argument("--hidden", type=int, nargs="+", default=[300, 300])
    p.add_argument("--set", action="append", default=[], help="KEY=VALUE for our runs")
    p.add_argument("--tiny", action="store_true", help="16-16 networks, batch 16, short "
                   "random phase: smoke tests only")
    p.add_argument("--estimate-only", action="store_true")
    p.add_argument("--no-gif", action="store_true")
    a = p.parse_args(argv)
    env_id, episodes, every = ENVS[a.env]
    a.episodes, a.eval_every = a.episodes or episodes, a.eval_every or every
    if a.tiny:
        a.hidden = [16, 16] if a.hidden == [300, 300] else a.hidden
    out = a.out or Path("results/gym-demo") / a.env
    if any(m in SB3 for m in a.methods):
        try:
            import stable_baselines3  # noqa: F401
        except ImportError:
            p.error("--methods includes " + ", ".join(m for m in a.methods if m in SB3)
                    + ", which needs stable-baselines3: pip install -e \".[bench]\" (or "
                    "leave them out of --methods)")
    from hiddpg.host import make_host_env

    horizon = make_host_env("gym:" + env_id).horizon
    steps = a.episodes * horizon
    rates = read(out / "rates.json") or {}
    for m in a.methods:
        if m not in rates:
            rates[m] = probe(m, a, horizon)
            write(out / "rates.json", rates)
    total = sum(steps * len(a.seeds) / rates[m] for m in a.methods)
    print(f"{a.env}: {steps} steps per seed x {len(a.seeds)} seeds; steps per CPU-second "
          + ", ".join(f"{m} {rates[m]:.0f}" for m in a.methods) + f"; expected "
          f"{total / 3600:.1f} CPU-hours (+ evaluations, less what is done): the wall time "
          "on an otherwise idle machine, or less where a method keeps two cores busy; more "
          "under load", flush=True)
    if a.estimate_only:
        return 0
    for m in a.methods:
        (run_ours if m in OURS else run_sb3)(m, a, out, horizon)
    summarize(out, [*OURS, *SB3], f"{a.env}: evaluation return, mean ± std over seeds")
    gif, run = out / "hi-ddpg.gif", out / "runs" / f"hi-ddpg-{part_name(a.seeds)}"
    if "hi-ddpg" in a.methods and not a.no_gif and not gif.is_file() and run.is_dir():
        from hiddpg import cli

        cli.main(["eval", str(run), "--gif", str(gif)])
    return 0


if __name__ == "__main__":
    sys.exit(main())
