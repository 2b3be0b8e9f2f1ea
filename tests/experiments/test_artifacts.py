"""Artifacts and ``hiddpg report``: the figures drawn from the artifacts alone carry the numbers
drawn from the run directories.

End to end: a tiny ``hiddpg reproduce`` (Figs. 3-5 from one run of 2 seeds x 20 episodes),
then ``hiddpg report`` on a copy without its ``runs/``. Figs. 6 and 8 (snapshots with
collisions, progress of the runs, success rates) on synthetic run directories; sizes on a
synthetic run of the paper's budget (15 seeds x 3000 episodes).
"""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from tiny_output import TINY, copy_output

from hiddpg.commands import report as report_cmd
from hiddpg.commands import reproduce
from hiddpg.experiments import arm, comparison
from hiddpg.experiments.artifacts import export_run, load_artifact
from hiddpg.experiments.common import Context
from hiddpg.experiments.rundata import block_means, load_run
from hiddpg.experiments.snapshots import (
    SNAPSHOT_DIR,
    Snapshot,
    snapshot_name,
    snapshots_from_json,
    snapshots_to_json,
)
from hiddpg.presets import make_config
from hiddpg.runs import Run

PNG_MAGIC, PDF_MAGIC = b"\x89PNG\r\n\x1a\n", b"%PDF-"
DRAWN = ("fig3", "fig4", "fig5")


def _numbers(out, name):
    return json.loads((out / "sections" / f"{name}.json").read_text())["numbers"]


@pytest.fixture(scope="module")
def reproduced(tiny_fig4, tmp_path_factory):
    out = copy_output(tiny_fig4, tmp_path_factory.mktemp("reproduce") / "out")
    for name in ("fig3", "fig5"):  # reuse fig4's run
        assert reproduce.main([name, "--out", str(out), *TINY]) == 0
    return out


@pytest.fixture(scope="module")
def redrawn(reproduced, tmp_path_factory):
    """A copy of the output with only its artifacts, redrawn by ``hiddpg report``."""
    out = tmp_path_factory.mktemp("report") / "out"
    shutil.copytree(reproduced / "artifacts", out / "artifacts")
    assert report_cmd.main([str(out)]) == 0
    return out


def test_report_draws_the_same_numbers_from_the_artifacts_alone(reproduced, redrawn, capsys):
    assert not (redrawn / "runs").exists()
    for name in DRAWN:
        assert _numbers(redrawn, name) == _numbers(reproduced, name), name
        for suffix, magic in ((".png", PNG_MAGIC), (".pdf", PDF_MAGIC)):
            assert (redrawn / "figures" / f"{name}{suffix}").read_bytes().startswith(magic)
    text = (redrawn / "report.md").read_text()
    assert text.startswith("# HI-DDPG reproduction: variant quick, quick scale")
    assert "Redrawn by `hiddpg report`" in text and "![fig4](figures/fig4.png)" in text
    assert report_cmd.main([str(redrawn), "fig4"]) == 0
    printed = capsys.readouterr().out
    assert "fig4: figures/fig4.png, figures/fig4.pdf" in printed and "wrote " in printed


def test_artifacts_are_small_and_describe_themselves(reproduced):
    art = reproduced / "artifacts" / "hi-ddpg-PuckTrajectory2"
    meta = json.loads((art / "meta.json").read_text())
    assert (meta["algo"], meta["seeds"], meta["episodes"], meta["status"]) == (
        "hi-ddpg", [0, 1], 20, "finished")
    assert meta["hiddpg_version"] and meta["training_block"] == 1
    assert meta["snapshot_episodes"] == [20]
    assert sorted(p.name for p in art.iterdir()) == sorted([*meta["files"], "meta.json"])
    assert sum(p.stat().st_size for p in art.iterdir()) < 20_000
    run = load_run(reproduced / "runs" / "hi-ddpg-PuckTrajectory2")
    data = load_artifact(art)
    np.testing.assert_array_equal(data.series("eval_env_return")[1],
                                  run.series("eval_env_return")[1])


def test_missing_directory_or_artifacts_exit_2(reproduced, tmp_path, capsys):
    assert report_cmd.main([str(tmp_path / "missing")]) == 2
    assert report_cmd.main([str(tmp_path)]) == 2
    assert report_cmd.main([str(reproduced), "fig6"]) == 2
    assert report_cmd.main([str(reproduced), "fig9"]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 4 and all(line.startswith("hiddpg report: error: ") for line in lines)
    assert "is not a directory" in lines[0] and "holds no artifact" in lines[1]
    assert "hi-ddpg-ArmObstacle" in lines[2] and "'fig9'" in lines[3]
    assert not any(tmp_path.iterdir())


# -------------------------------------------------------------------------- units, synthetic


def test_training_blocks_average_whole_blocks_counted_back_from_the_last_episode():
    values = np.arange(2 * 205, dtype=float).reshape(2, 205)
    blocks = block_means(np.arange(1, 206), {"return": values, "other": values})
    assert blocks.size == 2 and list(blocks.means) == ["return"]  # 205 // 100 episodes
    assert blocks.ends.tolist() == list(range(3, 206, 2))  # episode 1 left out
    np.testing.assert_allclose(blocks.means["return"][:, 0], values[:, 1:3].mean(axis=1))
    np.testing.assert_allclose(blocks.means["return"].mean(axis=1), values[:, 1:].mean(axis=1))
    small = block_means(np.arange(1, 21), {"return": values[:, :20]})
    assert small.size == 1 and np.array_equal(small.means["return"], values[:, :20])


def test_snapshot_json_keeps_exact_values_and_rounds_positions():
    rng = np.random.default_rng(0)
    alive = np.ones((2, 6), bool)
    alive[1, 4:] = False
    goal = np.repeat(rng.normal(size=(2, 2, 2)).astype(np.float32), 3, axis=1)
    traj = {"alive": alive, "switch": np.tile([1, 0, 0, 1, 0, 0], (2, 1)).astype(bool),
            "goal": goal, "reward": rng.normal(size=(2, 6)).astype(np.float32),
            "action": rng.normal(size=(2, 6, 3)).astype(np.float32),
            "obs": rng.normal(size=(2, 6, 4)).astype(np.float32),
            "next_obs": rng.normal(size=(2, 6, 4)).astype(np.float32),
            "duration": np.ones((2, 6), np.float32)}
    metrics = {"env_return": rng.normal(size=2).astype(np.float32)}
    first, last = snapshots_from_json(snapshots_to_json(
        [Snapshot(10, metrics, traj), Snapshot(20, metrics, traj)]))
    assert (first.episode, last.episode) == (10, 20)
    for key in ("alive", "switch", "goal", "reward"):
        assert last.traj[key].dtype == traj[key].dtype
        np.testing.assert_array_equal(last.traj[key], traj[key])
    np.testing.assert_array_equal(last.metrics["env_return"], metrics["env_return"])
    np.testing.assert_array_equal(last.traj["action"], traj["action"])
    assert "action" not in first.traj and "duration" not in last.traj
    np.testing.assert_allclose(last.traj["next_obs"], traj["next_obs"][..., :2], rtol=1e-4)
    np.testing.assert_allclose(last.traj["obs"], traj["obs"][:, :1, :2], rtol=1e-4)


def _synthetic_run(path, algo, task, seeds, episodes, horizon, rng, every=20, chunk=250):
    """A run directory of float32 metrics, progress and snapshots, without training."""
    run = Run.create(path, make_config(algo, task, "quick", [f"episodes={episodes}",
                                                             f"eval_every={every}"]),
                     list(range(seeds)))
    f32 = lambda a: np.asarray(a, np.float32)  # noqa: E731
    ep = np.tile(np.arange(1, episodes + 1), (seeds, 1))
    ret = f32(rng.normal(-50, 10, ep.shape))
    ev = ep[:, every - 1::every]
    score = f32(rng.normal(-40, 5, ev.shape))
    run.append_metrics(
        {"episode": ep, "length": np.full(ep.shape, horizon), "return": ret,
         "env_return": ret + 1, "switches": f32(rng.integers(0, 4, ep.shape))},
        {"episode": ev, "return": score, "env_return": score + 1,
         "switches": f32(rng.integers(0, 4, ev.shape))})
    run.write_progress(episodes, 12.5, "finished")
    (path / SNAPSHOT_DIR).mkdir()
    act = 6 if task == "ArmObstacle" else 2
    for e in range(chunk, episodes + 1, chunk):
        pos = f32(np.cumsum(rng.normal(0, 0.05, (seeds, horizon + 1, 4)), axis=1) + 0.7)
        alive = np.arange(horizon)[None] < np.where(np.arange(seeds) == 1, horizon // 2,
                                                    horizon)[:, None]  # run 1 collides
        reward = f32(-rng.uniform(0.0, 0.5, (seeds, horizon)))
        reward[:, -1], reward[0, -1], reward[1, horizon // 2 - 1] = -0.4, -0.001, -100.0
        traj = {"obs": pos[:, :-1], "alive": alive, "reward": reward,
                "action": f32(rng.uniform(-1, 1, (seeds, horizon, act)))}
        if algo.startswith("hi-ddpg"):
            thirds = [horizon // 3, horizon // 3, horizon - 2 * (horizon // 3)]
            switch = np.zeros((seeds, horizon), bool)
            switch[:, [0, thirds[0], 2 * thirds[0]]] = True
            traj.update(next_obs=pos[:, 1:], switch=switch,
                        goal=f32(np.repeat(rng.normal(1, 0.3, (seeds, 3, 2)), thirds, axis=1)))
        arrays = {"metric_env_return": (reward * alive).sum(1),
                  "metric_switches": f32(np.full(seeds, 2.0))}
        arrays.update({f"traj_{k}": v for k, v in traj.items()})
        np.savez(path / SNAPSHOT_DIR / snapshot_name(e), episode=e, **arrays)
    return path


@pytest.mark.parametrize("task,horizon", [("PuckTrajectory2", 30), ("ArmObstacle", 75)])
def test_a_paper_scale_artifact_is_well_under_a_megabyte(tmp_path, task, horizon):
    rng = np.random.default_rng(3)
    path = _synthetic_run(tmp_path / "run", "hi-ddpg", task, 15, 3000, horizon, rng)
    art = export_run(path, tmp_path / "artifact")
    sizes = {p.name: p.stat().st_size for p in art.iterdir()}
    assert sum(sizes.values()) < 800_000 and sizes["training.csv"] < 100_000, sizes
    run, data = load_run(path), load_artifact(art)
    assert data.training.size == 30 and data.training.ends[-1] == 3000
    for column in ("return", "switches"):
        np.testing.assert_array_equal(data.training.means[column], run.training.means[column])
    assert len(data.snapshots()) == 12


def test_fig6_and_fig8_numbers_from_artifacts_equal_those_from_runs(tmp_path, monkeypatch):
    rng = np.random.default_rng(4)
    train = Context(tmp_path / "train", seeds=3)
    for algo in ("hi-ddpg", "ddpg"):
        path = _synthetic_run(train.run_path(algo, "ArmObstacle"), algo, "ArmObstacle", 3, 500,
                              75, rng)
        export_run(path, train.artifact_path(algo, "ArmObstacle"))
    monkeypatch.setattr(arm, "ensure_run", lambda ctx, algo, task: ctx.run_path(algo, task))
    monkeypatch.setattr(comparison, "ensure_run",
                        lambda ctx, algo, task: ctx.run_path(algo, task))
    monkeypatch.setattr(comparison, "available",
                        lambda ctx, algo, task: None if algo in ("hi-ddpg", "ddpg") else "no")
    arm.fig6(train), comparison.run_comparison(train, "fig8")
    from_runs = {name: _numbers(train.out, name) for name in ("fig6", "fig8")}
    monkeypatch.undo()
    shutil.rmtree(train.out / "runs")
    again = Context(train.out, seeds=3, from_artifacts=True)
    arm.fig6(again), comparison.run_comparison(again, "fig8")
    assert {name: _numbers(again.out, name) for name in from_runs} == from_runs
    fig6, fig8 = from_runs["fig6"], from_runs["fig8"]
    assert fig6["success"] == [True, False, False] and fig6["collision"] == [False, True, False]
    assert fig8["success_rate"] == {"HI-DDPG": 1 / 3, "DDPG": 1 / 3}
    assert len(fig8["pairs"]) == 1 and len(fig8["stages"]) == 10
