"""The run directory (hiddpg.runs): atomic files, metrics rows, truncation, checkpoints."""

from __future__ import annotations

import json
import os
import sys

import jax.numpy as jnp
import numpy as np
import pytest

from hiddpg import run_check, runs
from hiddpg.configs import from_dict, to_dict
from hiddpg.machine import describe
from hiddpg.presets import make_config
from hiddpg.train import RunState

SEEDS = (3, 5)


def _config():
    return make_config("ddpg", "PuckTrajectory1", "quick",
                       ["episodes=20", "eval_every=5", "chunk_episodes=10"])


def _chunk(first: int, n: int, every: int = 5, with_steps: bool = False):
    """Synthetic engine output for 2 seeds: train (seeds, n), eval (seeds, n // every)."""
    ep = np.arange(first, first + n, dtype=np.int32)[None].repeat(len(SEEDS), 0)
    train = {"episode": ep, "return": -ep.astype(np.float32) / 3,
             "env_return": -ep.astype(np.float32), "length": np.full_like(ep, 30),
             "switches": np.zeros_like(ep), "critic_loss": ep.astype(np.float32) * 0.1,
             "q_mean": np.ones(ep.shape, np.float32)}
    if with_steps:
        train["env_steps"] = ep * 7
    ev = ep[:, every - 1::every]
    evals = {"episode": ev, "return": ev.astype(np.float32) + 0.5,
             "env_return": ev.astype(np.float32), "length": np.full_like(ev, 30),
             "switches": np.ones_like(ev)}
    return train, evals


@pytest.mark.parametrize("algo,task,preset,sets", [
    ("ddpg", "PuckTrajectory1", "paper", []),
    ("ddpg", "ArmReach", "quick", ["agent.hidden=[8,8,8]", "agent.noise.kind=gaussian"]),
    ("hi-ddpg", "PuckTrajectory2", "paper", ["agent.low.lr=3e-4", "env.max_steps=40"]),
    ("hi-ddpg-wo-model", "ArmObstacle", "quick", []),
])
def test_config_round_trip(algo, task, preset, sets):
    cfg = make_config(algo, task, preset, sets)
    assert from_dict(to_dict(cfg)) == cfg
    assert from_dict(json.loads(json.dumps(to_dict(cfg)))) == cfg


def test_create_and_open(tmp_path):
    cfg = _config()
    run = runs.Run.create(tmp_path / "r", cfg, SEEDS)
    meta = json.loads((tmp_path / "r" / runs.CONFIG_FILE).read_text())
    assert meta["seeds"] == list(SEEDS) and set(meta["versions"]) >= {"hiddpg", "jax"}
    assert run.progress() == {"episodes": 0, "total_episodes": 20, "wall_time": 0.0,
                              "status": "running",
                              "machines": [{"machine": describe(), "episodes": [0, 0],
                                            "wall_time": 0.0}]}
    again = runs.Run.open(tmp_path / "r")
    assert again.config == cfg and again.seeds == SEEDS
    with pytest.raises(FileExistsError):
        runs.Run.create(tmp_path / "r", cfg, SEEDS)
    with pytest.raises(FileNotFoundError, match="not a run directory"):
        runs.Run.open(tmp_path)


def test_atomic_write_replaces_and_leaves_no_temp(tmp_path, monkeypatch):
    target = tmp_path / "f.bin"
    runs.atomic_write(target, b"one")
    runs.atomic_write(target, b"two")
    assert target.read_bytes() == b"two" and os.listdir(tmp_path) == ["f.bin"]
    assert target.stat().st_mode & 0o777 == runs.FILE_MODE

    def crash(fd):
        raise OSError("disk full")

    monkeypatch.setattr(runs.os, "fsync", crash)
    with pytest.raises(OSError, match="disk full"):
        runs.atomic_write(target, b"three-partial")
    assert target.read_bytes() == b"two" and os.listdir(tmp_path) == ["f.bin"]


def test_metrics_rows_columns_and_eval(tmp_path):
    run = runs.Run.create(tmp_path / "r", _config(), SEEDS)
    run.append_metrics(*_chunk(1, 10))
    rows = run.read_metrics()
    assert list(rows[0]) == list(runs.METRIC_COLUMNS) + [
        "critic_loss", "eval_env_return", "eval_length", "eval_switches", "q_mean"]
    assert len(rows) == 20
    # episode-major, then seed; env_steps accumulate the lengths when the agent gives none
    assert [(int(r["episode"]), int(r["seed"])) for r in rows[:4]] == [(1, 3), (1, 5), (2, 3),
                                                                        (2, 5)]
    assert [int(r["env_steps"]) for r in rows if r["seed"] == "5"] == list(range(30, 301, 30))
    evaluated = {int(r["episode"]): r for r in rows if r["eval_return"]}
    assert sorted(evaluated) == [5, 10]
    assert float(evaluated[10]["eval_return"]) == 10.5
    assert evaluated[5]["eval_switches"] == "1"
    assert all(r["eval_env_return"] == "" for r in rows if not r["eval_return"])
    # float32 values survive the text round trip exactly
    ret = np.array([float(r["return"]) for r in rows if r["seed"] == "3"], np.float32)
    np.testing.assert_array_equal(ret, -np.arange(1, 11, dtype=np.float32) / 3)


def test_header_fixed_by_first_chunk_and_agent_env_steps(tmp_path):
    run = runs.Run.create(tmp_path / "r", _config(), SEEDS)
    train, evals = _chunk(1, 10, with_steps=True)
    run.append_metrics(train, evals)
    train, evals = _chunk(11, 10, with_steps=True)
    train["new_metric"] = train["return"]
    del train["q_mean"]
    run.append_metrics(train, evals)
    lines = run.metrics_path.read_text().splitlines()
    assert len(lines) == 41 and lines.count(lines[0]) == 1 and "new_metric" not in lines[0]
    rows = run.read_metrics()
    assert rows[-1]["q_mean"] == "" and rows[-1]["env_steps"] == str(20 * 7)


def test_truncate_drops_rows_past_checkpoint_and_continues_steps(tmp_path):
    run = runs.Run.create(tmp_path / "r", _config(), SEEDS)
    run.append_metrics(*_chunk(1, 10))
    run.append_metrics(*_chunk(11, 10))
    with open(run.metrics_path, "a") as f:
        f.write("3,21,63")  # a torn line from a crash mid-write
    reopened = runs.Run.open(tmp_path / "r")
    assert reopened.truncate_metrics(10) == 21
    rows = reopened.read_metrics()
    assert len(rows) == 20 and max(int(r["episode"]) for r in rows) == 10
    reopened.append_metrics(*_chunk(11, 10))
    fresh = runs.Run.create(tmp_path / "fresh", _config(), SEEDS)
    fresh.append_metrics(*_chunk(1, 10))
    fresh.append_metrics(*_chunk(11, 10))
    assert reopened.metrics_path.read_bytes() == fresh.metrics_path.read_bytes()
    assert reopened.truncate_metrics(20) == 0


class _FakeTrainer:
    """Just enough of a Trainer for checkpoint tests: ``init_seeds`` gives the structure."""

    def init_seeds(self, keys):
        n = keys.shape[0]
        agent = {"params": {"w": jnp.zeros((n, 4, 3)), "b": jnp.zeros((n, 3))},
                 "count": jnp.zeros((n,), jnp.int32)}
        return RunState(agent=agent, key=keys, episode=jnp.zeros((n,), jnp.int32))


def test_checkpoint_round_trip(tmp_path):
    run = runs.Run.create(tmp_path / "r", _config(), SEEDS)
    trainer = _FakeTrainer()
    state, done = run.load_checkpoint(trainer)
    assert done == 0
    state = state.replace(
        agent={"params": {"w": jnp.arange(24.0).reshape(2, 4, 3), "b": jnp.ones((2, 3))},
               "count": jnp.array([7, 9], jnp.int32)},
        episode=jnp.array([10, 10], jnp.int32))
    run.save_checkpoint(state)
    loaded, done = runs.Run.open(run.path).load_checkpoint(trainer)
    assert done == 10
    for a, b in zip(jax_leaves(loaded), jax_leaves(state), strict=True):
        np.testing.assert_array_equal(a, b)
    assert sorted(os.listdir(run.path)) == [runs.CHECKPOINT_FILE, runs.CONFIG_FILE,
                                            runs.PROGRESS_FILE, "writer.lock"]
    run.save_checkpoint(state.replace(episode=jnp.array([10, 20], jnp.int32)))
    with pytest.raises(ValueError, match="different episodes"):
        run.load_checkpoint(trainer)


def jax_leaves(tree):
    import jax

    return jax.tree.leaves(tree)


def test_find_non_finite_reports_earliest_loss():
    train, _ = _chunk(1, 10)
    assert run_check.find_non_finite(train, SEEDS) is None
    train["return"][0, 0] = np.nan  # not a loss metric: ignored
    train["actor_loss"] = np.zeros((2, 10), np.float32)
    train["actor_loss"][1, 6] = np.inf
    train["critic_loss"][0, 8] = np.nan
    assert run_check.find_non_finite(train, SEEDS) == ("actor_loss", 5, 7)


def test_tensorboard_events_and_missing_tensorboardx(tmp_path, monkeypatch, capsys):
    run = runs.Run.create(tmp_path / "r", _config(), SEEDS)
    run.write_tensorboard(*_chunk(1, 10))
    run.close()
    for s in SEEDS:
        assert any(f.startswith("events.out.tfevents")
                   for f in os.listdir(run.path / runs.TB_DIR / f"seed_{s}"))
    monkeypatch.setitem(sys.modules, "tensorboardX", None)
    run2 = runs.Run.create(tmp_path / "r2", _config(), SEEDS)
    run2.write_tensorboard(*_chunk(1, 10))
    run2.write_tensorboard(*_chunk(11, 10))
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "tensorboardX is not installed" in err[0]
    assert not (run2.path / runs.TB_DIR).exists()


def test_cell_formatting():
    assert runs._cell(np.float32(1 / 3)) == "0.333333343"
    assert np.float32(float(runs._cell(np.float32(1 / 3)))) == np.float32(1 / 3)
    assert runs._cell(np.int32(7)) == "7" and runs._cell(np.bool_(True)) == "1"
    assert runs._cell(np.float32(np.nan)) == "nan" and runs._cell(-np.inf) == "-inf"
