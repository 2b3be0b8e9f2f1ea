"""Every figure names what it draws: the legends of ``hiddpg plot``'s comparison and of Figs.
3-6, drawn from synthetic runs (no training), hold an entry for each kind of line, marker and
band, and every labelled artist appears in a legend."""

from __future__ import annotations

import numpy as np
import pytest

from hiddpg.experiments import arm, comparison, trajectory
from hiddpg.experiments.common import Context
from hiddpg.experiments.report import pyplot
from hiddpg.experiments.rundata import SNAPSHOT_DIR, RunData
from hiddpg.presets import make_config

SEEDS = (0, 1, 2)


def legend_labels(fig) -> set[str]:
    return {t.get_text() for ax in fig.axes if ax.get_legend()
            for t in ax.get_legend().get_texts()}


def assert_labelled_artists_in_legends(fig) -> None:
    shown = legend_labels(fig)
    for ax in fig.axes:
        for artist in (*ax.lines, *ax.collections, *ax.patches):
            label = artist.get_label()
            if label and not label.startswith("_"):
                assert label in shown, f"{label!r} is labelled but in no legend"


def run_data(tmp_path, algo, task, metrics, snapshots=()) -> RunData:
    """A RunData with ``metrics`` (column -> (seeds, episodes)) and snapshot files."""
    path = tmp_path / f"{algo}-{task}"
    (path / SNAPSHOT_DIR).mkdir(parents=True)
    for episode, snap_metrics, traj in snapshots:
        arrays = {f"metric_{k}": v for k, v in snap_metrics.items()}
        arrays.update({f"traj_{k}": v for k, v in traj.items()})
        np.savez(path / SNAPSHOT_DIR / f"episode_{episode:06d}.npz", episode=episode, **arrays)
    episodes = np.arange(1, next(iter(metrics.values())).shape[1] + 1)
    return RunData(path, make_config(algo, task, "quick"), SEEDS, episodes, metrics)


def trajectory_snapshot(episode, horizon, rng):
    """One noise-free episode per seed on a puck task: a random walk, goals switched at 0 and
    at the middle."""
    n = len(SEEDS)
    pos = np.cumsum(rng.normal(0, 0.1, (n, horizon + 1, 4)), axis=1)
    switch = np.zeros((n, horizon))
    switch[:, [0, horizon // 2]] = 1
    goal = np.where(np.arange(horizon)[None, :, None] < horizon // 2, 1.0, -1.0) * np.ones(
        (n, horizon, 2))
    traj = {"obs": pos[:, :-1], "next_obs": pos[:, 1:], "alive": np.ones((n, horizon)),
            "switch": switch, "goal": goal, "action": rng.uniform(-1, 1, (n, horizon, 2)),
            "reward": -rng.uniform(0, 1, (n, horizon))}
    metrics = {"env_return": traj["reward"].sum(1), "switches": np.ones(n)}
    return episode, metrics, traj


@pytest.fixture
def figures(monkeypatch):
    """The figures the experiment modules save, instead of writing them."""
    drawn = []

    def capture(fig, stem, note=None):
        drawn.append(fig)
        return [stem.with_name(stem.name + ".png")]

    for module in (trajectory, arm, comparison):
        monkeypatch.setattr(module, "save_figure", capture)
    yield drawn
    pyplot().close("all")


def test_comparison_legend_names_methods_and_bands():
    rng = np.random.default_rng(0)
    runs = {label: RunData(None, make_config(algo, "PuckObstacle", "quick"), SEEDS,
                           np.arange(1, 11), {"eval_env_return": rng.normal(0, 1, (3, 10))})
            for label, algo in (("DDPG", "ddpg"), ("HI-DDPG", "hi-ddpg"))}
    fig = comparison.plot_comparison(comparison.compare(runs, n_stages=2), "t")
    curves, tiles = fig.axes[0], fig.axes[1]
    assert [t.get_text() for t in curves.get_legend().get_texts()] == [
        "DDPG: mean of 3 runs", "HI-DDPG: mean of 3 runs", comparison.BAND_LABEL]
    assert any(ax.get_ylabel() == comparison.TILE_LABEL for ax in fig.axes[2:])  # colour bar
    assert tiles.get_ylabel() == "A vs B"
    assert_labelled_artists_in_legends(fig)
    pyplot().close(fig)


def test_fig3_fig4_fig5_legends(tmp_path, monkeypatch, figures):
    rng = np.random.default_rng(1)
    task, horizon = "PuckTrajectory2", 30
    snaps = [trajectory_snapshot(e, horizon, rng) for e in (10, 20)]
    metrics = {"return": rng.normal(-30, 1, (3, 20)), "switches": rng.integers(0, 3, (3, 20))}
    run = run_data(tmp_path, "hi-ddpg", task, metrics, snaps)
    monkeypatch.setattr(trajectory, "_runs", lambda ctx, tasks: {t: run for t in tasks})
    monkeypatch.setattr(trajectory, "ilqr_actions", lambda *a: (np.zeros((horizon, 2)), True))
    ctx = Context(tmp_path, tasks=(task,))
    trajectory.fig3(ctx), trajectory.fig4(ctx), trajectory.fig5(ctx)
    fig3, fig4, fig5 = figures
    top, bottom = fig3.axes
    assert {"mean over 3 runs", "± std over runs"} == {
        t.get_text() for t in top.get_legend().get_texts()}
    assert "reference's switches" in {t.get_text() for t in bottom.get_legend().get_texts()}
    left, right = fig4.axes
    reference, generated = (t.get_text() for t in left.get_legend().get_texts())
    assert reference == "reference" and generated.startswith("generated (run ")
    assert generated.endswith("episodes 10-20; fainter: earlier)")
    assert {"reference trajectory", "learned goals (every run)", "reference goals"} == {
        t.get_text() for t in right.get_legend().get_texts()}
    assert {"goal", "low-level action", "iLQR action"} <= legend_labels(fig5)
    for fig in figures:
        assert_labelled_artists_in_legends(fig)


def test_fig6_legends(tmp_path, monkeypatch, figures):
    rng = np.random.default_rng(2)
    n, horizon = len(SEEDS), 75
    angles = np.cumsum(rng.normal(0, 0.02, (n, horizon + 1, 4)), axis=1) + [0.5, 1.5, 0, 0]
    switch = np.zeros((n, horizon))
    switch[:, [0, 30]] = 1
    traj = {"obs": angles[:, :-1], "next_obs": angles[:, 1:], "alive": np.ones((n, horizon)),
            "switch": switch, "goal": np.tile([[0.8, 1.2]], (n, horizon, 1)),
            "reward": -rng.uniform(0, 0.5, (n, horizon))}
    snaps = [(e, {"env_return": traj["reward"].sum(1), "switches": np.ones(n)}, traj)
             for e in (300, 400)]
    metrics = {"eval_env_return": np.where(np.arange(400) % 100 == 99, -5.0, np.nan)[None]
               * np.ones((n, 1))}
    run = run_data(tmp_path, "hi-ddpg", "ArmObstacle", metrics, snaps)
    monkeypatch.setattr(arm, "ensure_run", lambda *a: run.path)
    monkeypatch.setattr(arm, "load_run", lambda path: run)
    arm.fig6(Context(tmp_path))
    (fig,) = figures
    labels = legend_labels(fig)
    assert {f"arm, {arm.POSTURES} postures (blue: start, green: end)", "hand path",
            "goals (numbered in order)", "target posture", "obstacle (collision zone)",
            "eval_env_return: mean of 3 runs", "± std over runs", "low-level pre-training",
            "success rate"} == labels
    assert_labelled_artists_in_legends(fig)
