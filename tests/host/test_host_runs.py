"""The run loop (:mod:`hiddpg.runner`) with the host engine: a ``gym:`` task gets a
:class:`~hiddpg.host.HostTrainer` from ``make_trainer``; run directory, metrics, TensorBoard and
checkpoints as for the JAX engine; a run interrupted after its first chunk and resumed, and one
extended by ``--resume --episodes``, end with the files of an uninterrupted run, bit for bit
(the puck is deterministic given its seed; every episode's reset seed comes from the run's
keys, so no environment state needs a checkpoint)."""

from __future__ import annotations

import dataclasses
import importlib.util
import json

import numpy as np
import pytest

from hiddpg import runs
from hiddpg.host import HostTrainer, gym_task, register_gym_task, unregister_gym_task
from hiddpg.presets import make_config
from hiddpg.runner import FINISHED, INTERRUPTED, open_for_resume, prepare_new, train_run
from hiddpg.runs import make_trainer

#: the tiny DDPG of test_host_parity.py (the same engine: its steps compile once per process)
CONFIG = dataclasses.replace(
    make_config("ddpg", "PuckTrajectory1", "quick",
                ["episodes=6", "eval_every=2", "chunk_episodes=2", "agent.hidden=[8,8]",
                 "agent.learning_starts=10", "agent.buffer_size=200", "agent.batch_size=8"]),
    task="gym:hiddpg/PuckTrajectory1-v0")
SEEDS = [0, 1]


def files(path):
    return {f: (path / f).read_bytes() for f in (runs.METRICS_FILE, runs.CHECKPOINT_FILE)}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    path = tmp_path_factory.mktemp("host") / "ref"
    result = train_run(prepare_new(CONFIG, SEEDS, path), make_trainer(CONFIG))
    return path, result


def test_a_gym_task_trains_through_the_run_loop(reference):
    path, result = reference
    assert isinstance(make_trainer(CONFIG), HostTrainer)
    assert result.status == FINISHED and result.episodes == 6
    run = runs.Run.open(path)
    assert run.config == CONFIG and run.progress()["status"] == FINISHED
    rows = run.read_metrics()
    assert [(int(r["episode"]), int(r["seed"])) for r in rows] == [
        (e, s) for e in range(1, 7) for s in SEEDS]
    assert [int(r["env_steps"]) for r in rows if r["seed"] == "0"] == [30 * e for e in
                                                                      range(1, 7)]
    assert [int(r["episode"]) for r in rows if r["eval_return"] and r["seed"] == "1"] == [
        2, 4, 6]
    assert all(float(r["critic_loss"]) > 0 for r in rows)
    returns = np.array([float(r["return"]) for r in rows]).reshape(6, 2)
    assert not np.array_equal(returns[:, 0], returns[:, 1])  # seeds differ
    if importlib.util.find_spec("tensorboardX") is not None:
        assert {p.name for p in (path / runs.TB_DIR).iterdir()} == {"seed_0", "seed_1"}


def test_interrupted_then_resumed_equals_uninterrupted(reference, tmp_path):
    ref_path, _ = reference

    def stop(run, episodes):
        raise KeyboardInterrupt

    path = tmp_path / "stopped"
    result = train_run(prepare_new(CONFIG, SEEDS, path), make_trainer(CONFIG), on_chunk=stop)
    assert result.status == INTERRUPTED and result.episodes == 2
    run, trainer, done = open_for_resume(path)
    assert done == 2 and isinstance(trainer, HostTrainer)
    assert train_run(run, trainer).status == FINISHED
    assert files(path) == files(ref_path)


def test_a_shorter_run_extended_equals_the_longer_one(reference, tmp_path):
    ref_path, _ = reference
    path = tmp_path / "short"
    short = dataclasses.replace(CONFIG, episodes=4)
    assert train_run(prepare_new(short, SEEDS, path), make_trainer(short)).episodes == 4
    run, trainer, done = open_for_resume(path, episodes=6)
    assert done == 4 and trainer.config == CONFIG
    assert train_run(run, trainer).status == FINISHED
    assert files(path) == files(ref_path)


def test_a_run_records_its_gym_declaration_and_reopening_restores_it(reference, tmp_path):
    path, _ = reference
    meta = json.loads((path / runs.CONFIG_FILE).read_text())
    assert meta["gym_task"]["env"] == "hiddpg/PuckTrajectory1-v0"
    register_gym_task("Puck", "hiddpg/PuckTrajectory1-v0", goal={0: (-1, 3)}, dt=0.2)
    declared = gym_task("gym:Puck")
    try:
        config = dataclasses.replace(CONFIG, task="gym:Puck")
        runs.Run.create(tmp_path / "puck", config, SEEDS).close()
        unregister_gym_task("Puck")  # as in a new process
        assert runs.Run.open(tmp_path / "puck").config == config
        assert gym_task("gym:Puck") == declared
    finally:
        unregister_gym_task("Puck")
