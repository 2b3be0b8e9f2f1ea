"""Golden metrics: short runs of every algorithm x preset x task family (and the option sets
of ``hiddpg reproduce --scale paper``), recorded so that a refactor can show it changes no
number.

    python scripts/golden.py record tests/golden/metrics.json   # before
    python scripts/golden.py check  tests/golden/metrics.json   # after: bit for bit
    python scripts/golden.py merge  tests/golden/metrics.json   # a new metric: add its key

``merge`` adds the metric keys a case logs that the file lacks (a new logged quantity), keeps
every recorded value and digest, and says which recorded keys the case no longer logs.

Each case trains two seeds (0, 1) through ``make_train`` vmapped with the seed axis name (the
engine's gated updates) for a few episodes with small start-up phases, so that every learning
path runs. ``check`` compares every metric value exactly and a SHA-256 of the final agent
state (bit for bit on one machine); ``tests/test_golden.py`` compares the values with a
tolerance (other CPUs round differently).
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
from pathlib import Path

import jax
import numpy as np

from hiddpg.agents.gate import SEED_AXIS
from hiddpg.presets import make_config
from hiddpg.train import make_train, seed_keys

#: short budgets that still reach every phase: random, pre-training, learning, evaluation
SHORT = ("episodes=6", "eval_every=3", "chunk_episodes=3")
HI_SHORT = ("agent.learning_starts=40", "agent.high_learning_starts=4")
ARM_SHORT = ("agent.pretrain_episodes=2",)
# the option sets of ``hiddpg reproduce --scale paper`` (hiddpg.presets), fixed here so that a
# change of the presets does not change the golden cases
CRITIC_DURATIONS = (
    "agent.choice=critic-durations", "agent.choice.explore=0.5",
    "agent.model_weight=0", "agent.use_model=false",
    "agent.high.action_l2=0.1", "agent.low.noise.final_sigma=0",
    "agent.low_hindsight.fraction=0.8", "agent.rest_term.weight=0.3",
)
ARM_HIGH_CRITIC = ("agent.high_hindsight.probability=1", "agent.high.huber.delta=10",
                   "agent.high.huber.late_delta=3", "agent.high.huber.late_episode=4")

TASKS = ("PuckTrajectory1", "PuckObstacle", "ArmObstacle")
ALGOS = ("ddpg", "hi-ddpg", "hi-ddpg-wo-model", "h-ddpg")


def cases() -> dict[str, tuple[str, str, str, tuple[str, ...]]]:
    """name -> (algo, task, preset, sets)."""
    out = {}
    for preset in ("quick", "paper"):
        for task in TASKS:
            for algo in ALGOS:
                sets = SHORT
                if algo.startswith("hi-ddpg"):
                    sets += HI_SHORT + (ARM_SHORT if task.startswith("Arm") else ())
                elif algo == "ddpg":
                    sets += ("agent.learning_starts=40",)
                else:
                    sets += ("agent.skill.learning_starts=40",)
                if preset == "paper" and task == "PuckObstacle":
                    continue  # the paper preset's puck code paths run on PuckTrajectory1
                out[f"{algo}/{task}/{preset}"] = (algo, task, preset, sets)
    hi = SHORT + HI_SHORT
    out["hi-ddpg/PuckTrajectory2/quick+critic-durations"] = (
        "hi-ddpg", "PuckTrajectory2", "quick", hi + CRITIC_DURATIONS)
    out["hi-ddpg/ArmObstacle/quick+arm-high-critic"] = (
        "hi-ddpg", "ArmObstacle", "quick", hi + ARM_SHORT + ARM_HIGH_CRITIC)
    return out


def run(algo: str, task: str, preset: str, sets: tuple[str, ...]) -> dict:
    cfg = make_config(algo, task, preset, list(sets))
    train = jax.jit(jax.vmap(make_train(cfg), axis_name=SEED_AXIS))
    state, train_m, eval_m = train(seed_keys([0, 1]))
    leaves = [np.asarray(x) for x in jax.tree.leaves(state.agent) if np.size(x)]
    out = {"train": {k: np.asarray(v) for k, v in train_m.items()},
           "eval": {k: np.asarray(v) for k, v in eval_m.items()}}
    digest = hashlib.sha256()
    for part in ("train", "eval"):
        for k in sorted(out[part]):
            digest.update(k.encode() + out[part][k].tobytes())
    # order-free and without empty leaves: the state's pytree layout may change, its values
    # may not
    leaf_digests = sorted(hashlib.sha256(x.tobytes()).hexdigest() for x in leaves)
    state_digest = hashlib.sha256("".join(leaf_digests).encode()).hexdigest()
    return {"sha256": digest.hexdigest(), "state_sha256": state_digest,
            "values": {p: {k: v.astype(float).tolist() for k, v in out[p].items()}
                       for p in out}}


def main(argv: list[str]) -> int:
    mode, path = argv[0], argv[1]
    only = argv[2:]
    results = {}
    for name, case in cases().items():
        if only and not any(o in name for o in only):
            continue
        results[name] = run(*case)
        print(name, results[name]["sha256"][:12], results[name]["state_sha256"][:12],
              flush=True)
    if mode == "record":
        _write(path, results)
        return 0
    with open(path) as f:
        golden = json.load(f)
    if mode == "merge":
        return _merge(path, golden, results)
    bad = [n for n in results if _differs(golden[n], results[n])]
    for n in bad:
        print("DIFFERS:", n)
    print(f"{len(results) - len(bad)}/{len(results)} cases bit for bit")
    return 1 if bad else 0


def _write(path: str, results: dict) -> None:
    """Write ``results`` to ``path`` through a temporary file: never a half-written file."""
    tmp = Path(path).with_suffix(".tmp")
    tmp.write_text(json.dumps(results, indent=0, sort_keys=True))
    os.replace(tmp, path)


def _merge(path: str, golden: dict, results: dict) -> int:
    """Add the metric keys of ``results`` that ``golden`` lacks; 1 if a case is not in the
    file or a recorded key is no longer logged."""
    missing = [n for n in results if n not in golden]
    gone = []
    for name, new in results.items():
        if name in missing:
            continue
        for part in ("train", "eval"):
            held = golden[name]["values"][part]
            added = sorted(set(new["values"][part]) - set(held))
            held.update({k: new["values"][part][k] for k in added})
            gone += [f"{name}: {part}/{k}" for k in sorted(set(held) - set(new["values"][part]))]
            if added:
                print(f"{name}: added {part}/{', '.join(added)}")
    _write(path, golden)
    for line in [f"not in {path} (record it): {n}" for n in missing] + \
            [f"recorded but no longer logged: {g}" for g in gone]:
        print(line)
    return 1 if missing or gone else 0


def _differs(old: dict, new: dict) -> bool:
    """Whether any metric value (exactly, whatever its dtype) or the state's bits differ."""
    if old["state_sha256"] != new["state_sha256"]:
        return True
    return any(set(old["values"][p]) != set(new["values"][p])
               or any(not np.array_equal(np.asarray(old["values"][p][k], np.float64),
                                         np.asarray(new["values"][p][k], np.float64))
                      for k in old["values"][p])
               for p in ("train", "eval"))


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
