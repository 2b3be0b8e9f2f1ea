"""``hiddpg reproduce`` and ``hiddpg plot`` end to end on tiny budgets, and the figure maths.

The end-to-end run is Fig. 4 on one task (2 seeds, 20 episodes, hidden [16, 16]): it must write
valid PNG/PDF files and a report whose numbers parse; a second invocation must reuse the run
without training. Tiles, run-or-reuse decisions and success/goal measures are checked on
synthetic data.
"""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from tiny_output import TINY, copy_output

from hiddpg.commands import plot as plot_cmd
from hiddpg.commands import reproduce
from hiddpg.configs import ActionHindsight, HuberLoss
from hiddpg.experiments import comparison, report, stats
from hiddpg.experiments.arm import outcomes
from hiddpg.experiments.common import Context, ensure_run, expand_sets
from hiddpg.experiments.rundata import load_run
from hiddpg.experiments.trajectory import goal_distances
from hiddpg.presets import make_config
from hiddpg.runs import Run

PNG_MAGIC, PDF_MAGIC = b"\x89PNG\r\n\x1a\n", b"%PDF-"
RUN = "runs/hi-ddpg-PuckTrajectory2"


@pytest.fixture(scope="module")
def reproduced(tiny_fig4, tmp_path_factory):
    return copy_output(tiny_fig4, tmp_path_factory.mktemp("reproduce") / "out")


def _valid_figure(stem):
    assert stem.with_suffix(".png").read_bytes().startswith(PNG_MAGIC)
    assert stem.with_suffix(".pdf").read_bytes().startswith(PDF_MAGIC)


def test_fig4_writes_figures_and_a_report_whose_numbers_parse(reproduced):
    _valid_figure(reproduced / "figures" / "fig4")
    text = (reproduced / "report.md").read_text()
    assert "## Fig. 4" in text and "![fig4](figures/fig4.png)" in text
    task_rows = [r for r in report.table_rows(text) if r[0] == "PuckTrajectory2"]
    # one row per reference goal, then the bar, then the bar over training
    rows, (bar, history) = task_rows[:2], task_rows[2:]
    numbers = json.loads((reproduced / "sections" / "fig4.json").read_text())["numbers"]
    mine = numbers["PuckTrajectory2"]
    for g, row in enumerate(rows):
        near, seg = report.parse_numbers(row[2]), report.parse_numbers(row[3])
        switches, ref_switches = report.parse_numbers(row[4]), report.parse_numbers(row[5])
        ret = report.parse_numbers(row[6])
        assert len(near) == len(seg) == len(switches) == len(ret) == 2  # mean ± std
        assert near[0] >= 0 and seg[0] >= near[0] - 1e-2  # nearest is the smallest distance
        assert near[0] == pytest.approx(np.mean(np.array(mine["nearest_distance"])[:, g]),
                                        rel=1e-2)
        assert switches[0] == pytest.approx(np.mean(mine["switches"]), rel=1e-2)
        assert ref_switches == [1.0] and ret[0] < 0
    counts = mine["bar"]
    assert bar[1] == "0-1"  # the seeds the counts come from
    assert bar[2:] == [f"{counts[k]} / 2" for k in ("goals", "switches", "both")]
    assert counts["switches"] == sum(s == 1 for s in mine["switches"])
    episodes_runs = report.parse_numbers(history[1])  # "e1: n1, e2: n2, ..." (last: final)
    assert episodes_runs[-2:] == [mine["episode"], counts["both"]]
    assert [list(p) for p in mine["bar_history"]] == [
        [int(e), int(n)] for e, n in zip(episodes_runs[::2], episodes_runs[1::2], strict=True)]
    times = {r[0]: report.parse_numbers(r[1]) for r in report.table_rows(text)
             if "training" in r[0] or "fig4" in r[0]}
    assert all(v and v[0] > 0 for v in times.values())
    assert report.parse_numbers(report.budget_table().splitlines()[2])[0] == 3  # quick seeds
    assert text.startswith("# HI-DDPG reproduction: variant quick, quick scale")
    assert json.loads((reproduced / "sections" / "fig4.json").read_text())["variant"] == "quick"


def test_every_figure_names_its_variant_at_its_foot(tmp_path):
    plt = report.pyplot()
    fig = plt.figure()
    note = Context(tmp_path, scale="paper", variant="paper+").note()
    report.save_figure(fig, tmp_path / "f", note)
    assert [t.get_text() for t in fig.texts] == [note]
    assert note.startswith("variant paper+: the paper") and note.endswith("(paper scale)")


def test_second_invocation_reuses_the_runs(reproduced, capsys):
    run = reproduced / RUN
    kept = sorted(p for p in run.rglob("*") if p.is_file() and "tb" not in p.parts)
    before = {p: (p.stat().st_mtime_ns, p.read_bytes()) for p in kept}
    figure = reproduced / "figures" / "fig4.png"
    figure_time = figure.stat().st_mtime_ns
    assert reproduce.main(["fig4", "--out", str(reproduced), *TINY]) == 0
    assert {p: (p.stat().st_mtime_ns, p.read_bytes()) for p in kept} == before
    assert figure.stat().st_mtime_ns > figure_time
    assert "finished, reused" in capsys.readouterr().err


def test_a_different_config_in_the_same_out_is_refused(reproduced, capsys):
    argv = ["fig4", "--out", str(reproduced), *TINY]
    argv[argv.index("--seeds") + 1] = "3"
    assert reproduce.main(argv) == 1
    assert "another config" in capsys.readouterr().err


def test_an_interrupted_run_is_resumed(reproduced, monkeypatch, tmp_path):
    from hiddpg import runner

    ctx = Context(tmp_path, seeds=2, episodes=20, sets=("agent.hidden=[16,16]",))
    target = ctx.run_path("hi-ddpg", "PuckTrajectory2")
    target.parent.mkdir(parents=True)
    shutil.copytree(reproduced / RUN, target)
    run = Run.open(target)
    run.write_progress(20, 1.0, "running")  # as a killed process leaves it
    calls = []

    def fake_train(opened, trainer, *, on_chunk=None, reporter=None):
        calls.append((opened.path, trainer.config.episodes))
        run.write_progress(20, 1.0, "finished")
        return runner.RunResult(runner.FINISHED, 20, 1.0)

    monkeypatch.setattr(runner, "train_run", fake_train)
    assert ensure_run(ctx, "hi-ddpg", "PuckTrajectory2") == target
    assert calls == [(target, 20)]
    ensure_run(ctx, "hi-ddpg", "PuckTrajectory2")  # finished now: no second call
    assert len(calls) == 1


def test_cli_dispatch_and_number_format(capsys):
    from hiddpg import cli

    assert cli.main(["reproduce", "--help"]) == 0 and cli.main(["plot", "--help"]) == 0
    assert "budgets per scale" in capsys.readouterr().out
    assert [report.fmt(x) for x in (-832.7, 0.005651, 12.34, float("nan"))] == [
        "-833", "0.00565", "12.3", "nan"]
    assert report.parse_numbers("-833 ± 3.4e+02 [nan, 1.00]") == pytest.approx(
        [-833, 340, float("nan"), 1.0], nan_ok=True)


def test_bad_command_lines_exit_2(tmp_path, capsys):
    assert reproduce.main(["fig9"]) == 2
    assert reproduce.main(["fig4", "--out", str(tmp_path), "--set", "agent.nope=1"]) == 2
    assert reproduce.main(["fig4", "--scale", "huge"]) == 2
    assert plot_cmd.main([str(tmp_path / "missing")]) == 2
    assert not any(tmp_path.iterdir())


# ----------------------------------------------------------------------- synthetic runs


def _synthetic_run(path, algo, offset, seeds=(0, 1, 2), episodes=40, every=4):
    """A run directory with metrics only: returns rise with the episode, plus ``offset``."""
    config = make_config(algo, "PuckObstacle", "quick", [f"episodes={episodes}",
                                                          f"eval_every={every}"])
    run = Run.create(path, config, seeds)
    rng = np.random.default_rng(round(10 * offset))
    ep = np.tile(np.arange(1, episodes + 1), (len(seeds), 1))
    ret = ep / 10 + offset + rng.normal(0, 1, ep.shape)
    train = {"episode": ep, "length": np.full(ep.shape, 50), "return": ret, "env_return": ret,
             "switches": np.zeros(ep.shape)}
    ev = ep[:, every - 1::every]
    score = ev / 10 + offset + rng.normal(0, 1, ev.shape)
    run.append_metrics(train, {"episode": ev, "return": score, "env_return": score})
    return path


def test_tiles_equal_pairwise_welch_on_stage_means(tmp_path):
    runs = {label: load_run(_synthetic_run(tmp_path / algo, algo, off))
            for label, algo, off in (("A", "ddpg", 0.0), ("B", "hi-ddpg", 5.0),
                                     ("C", "hi-ddpg-wo-model", 1.0))}
    comp = comparison.compare(runs, n_stages=5)
    assert comp.metric == "eval_env_return" and comp.episodes.tolist() == list(range(4, 41, 4))
    expected = {}
    for label, run in runs.items():
        values = run.metrics["eval_env_return"][:, 3::4]  # (seeds, 10 evaluations)
        expected[label] = values.reshape(3, 5, 2).mean(axis=2)  # 5 stages of 2 evaluations
        np.testing.assert_allclose(comp.scores[label], expected[label])
    ref = stats.pairwise_welch(expected)
    np.testing.assert_allclose(comp.welch.t, ref.t, equal_nan=True)
    np.testing.assert_allclose(comp.welch.p_holm, ref.p_holm, equal_nan=True)
    t, p = stats.welch_t(expected["B"], expected["A"])
    np.testing.assert_allclose(comp.welch.tile("B", "A"), stats.signed_log_p(t, p))
    assert comp.bounds == [(4, 8), (12, 16), (20, 24), (28, 32), (36, 40)]
    numbers = comparison.summary_numbers(comp)
    np.testing.assert_allclose(numbers["final"]["B"]["mean"], expected["B"][:, -1].mean())
    pair = next(q for q in numbers["pairs"] if (q["a"], q["b"]) == ("A", "B"))
    assert pair["t"] < 0 and pair["stages_b_better"] >= 1
    table = report.table_rows(comparison.summary_markdown(numbers))
    assert table[1][2] == "-"  # the numbers name no seeds (synthetic runs)
    assert report.parse_numbers(table[1][3])[0] == pytest.approx(
        numbers["final"]["B"]["mean"], rel=1e-2)


def test_plot_two_run_dirs_writes_a_figure(tmp_path, capsys):
    a = _synthetic_run(tmp_path / "runs" / "a", "ddpg", 0.0)
    b = _synthetic_run(tmp_path / "runs" / "b", "hi-ddpg", 2.0)
    assert plot_cmd.main([str(a), str(b), "--out", str(tmp_path / "cmp"), "--stages", "4"]) == 0
    _valid_figure(tmp_path / "cmp")
    out = capsys.readouterr().out
    assert "| DDPG | 3 |" in out and "DDPG vs HI-DDPG" in out
    assert plot_cmd.main([str(tmp_path / "runs"), "--out", str(tmp_path / "all")]) == 0
    _valid_figure(tmp_path / "all")


# --------------------------------------------------------------------- measures, options


def test_goal_distances_and_arm_outcomes():
    goal = np.array([[[1.0, 0.0]] * 2 + [[3.0, 1.0]] * 2, [[0.0, 0.0]] * 4])
    traj = {"goal": goal, "switch": np.array([[1, 0, 1, 0], [1, 0, 0, 0]]),
            "alive": np.ones((2, 4))}
    near, seg = goal_distances(traj, np.array([[1.0, 0.0], [3.0, 2.0]]), np.array([2]), 4)
    np.testing.assert_allclose(near, [[0.0, 1.0], [1.0, np.hypot(3, 2)]])
    np.testing.assert_allclose(seg, near)
    arm = {"reward": np.array([[-0.5, -0.01, 0.0], [-0.5, -100.0, 0.0], [-0.2, -0.1, -0.05]]),
           "alive": np.array([[1, 1, 1], [1, 1, 0], [1, 1, 1]])}
    success, collision = outcomes(arm, success_radius=0.03, horizon=3)
    assert success.tolist() == [True, False, False] and collision.tolist() == [False, True, False]


def test_hidden_override_reaches_every_hidden_field():
    hi = make_config("hi-ddpg", "PuckTrajectory1", "quick")
    assert expand_sets(hi, ["agent.hidden=[8]", "episodes=5"]) == [
        "agent.high.hidden=[8]", "agent.low.hidden=[8]", "episodes=5"]
    assert expand_sets(make_config("ddpg", "PuckTrajectory1", "quick"),
                       ["agent.hidden=[8]"]) == ["agent.hidden=[8]"]


def test_history_opacity_rises_to_one_and_never_past_it():
    from hiddpg.experiments.trajectory import history_alpha

    for n in range(1, 60):  # paper scale: 12 snapshots gave 1.0000000000000002 before
        alphas = [history_alpha(k, n) for k in range(n)]
        assert all(0.1 < a <= 1.0 for a in alphas) and alphas[-1] > 1.0 - 1e-12
        assert alphas == sorted(alphas)


def test_bar_counts_runs_with_every_goal_near_and_the_reference_switches():
    from hiddpg.experiments.trajectory import bar_counts

    near = np.array([[0.1, 0.2], [0.1, 0.35], [0.29, 0.0], [0.5, 0.5]])
    got = bar_counts(near, np.array([1.0, 1.0, 2.0, 1.0]), reference_switches=1)
    assert got == {"runs": 4, "goals": 2, "switches": 3, "both": 1}


def test_bar_history_counts_each_snapshot():
    from hiddpg.experiments.rundata import Snapshot
    from hiddpg.experiments.trajectory import bar_history

    def snap(episode, goal_rows, switches):
        goal = np.array(goal_rows, dtype=float)
        switch = np.zeros(goal.shape[:2])
        switch[:, 0] = 1
        switch[:, 2] = switches
        traj = {"goal": goal, "switch": switch, "alive": np.ones(goal.shape[:2])}
        return Snapshot(episode, {"switches": np.array(switches, float)}, traj)

    ref, steps = np.array([[1.0, 0.0], [3.0, 2.0]]), np.array([2])
    good, far = [[1.0, 0.1]] * 2 + [[3.0, 2.1]] * 2, [[1.0, 0.0]] * 2 + [[3.0, 2.5]] * 2
    snaps = [snap(10, [far, far], [1, 1]), snap(20, [good, far], [1, 1]),
             snap(30, [good, good], [1, 0])]
    assert bar_history(snaps, ref, steps, 4) == [(10, 0), (20, 1), (30, 1)]


def test_extended_variant_gets_the_critic_durations_and_6000_episodes(tmp_path):
    """Variant ``extended`` at paper scale: HI-DDPG on PuckTrajectory1-3 with
    ``CRITIC_DURATIONS`` for 6000 episodes, on ArmObstacle with ``ARM_HIGH_CRITIC``; the other
    tasks, the other algorithms and the quick scale keep the presets' budgets."""
    from hiddpg.experiments.budgets import variant_table

    paper = Context(tmp_path, scale="paper", variant="extended")
    quick = Context(tmp_path, scale="quick")
    assert quick.variant == "quick"
    for task in ("PuckTrajectory1", "hiddpg/PuckTrajectory3-v0"):
        cfg = paper.config("hi-ddpg", task)
        assert (cfg.episodes, cfg.agent.choice.kind) == (6000, "critic-durations")
        assert cfg.agent.low.noise.decay_episodes == 6000
        assert paper.config("ddpg", task).episodes == 6000  # the budget, not the sets
        small = quick.config("hi-ddpg", task)
        assert (small.episodes, small.agent.choice.kind) == (1500, "hold")
    for task in ("PuckObstacle", "ArmObstacle"):
        cfg = paper.config("hi-ddpg", task)
        assert (cfg.episodes, cfg.agent.choice.kind, cfg.preset) == (3000, "actor", "quick")
    # ArmObstacle: hindsight actions and the Huber high critic for both HI-DDPG variants only
    for algo in ("hi-ddpg", "hi-ddpg-wo-model"):
        agent = paper.config(algo, "ArmObstacle").agent
        assert (agent.high_hindsight, agent.high.huber, agent.low.huber) == (
            ActionHindsight(1.0), HuberLoss(10.0, 3.0, 2160), None)
        assert quick.config(algo, "ArmObstacle").agent.high.huber is None
        assert paper.config(algo, "PuckObstacle").agent.high_hindsight is None
    row = [r for r in variant_table().splitlines() if r.startswith("| extended")]
    assert len(row) == 1 and "choice=critic-durations" in row[0] and "trajectory 6000" in row[0]


@pytest.mark.parametrize("variant", ["paper", "paper+"])
def test_paper_variants_train_the_preset_itself_on_15_seeds(tmp_path, variant):
    """``--variant paper`` / ``paper+`` at paper scale: every run is ``make_config`` of that
    preset with only the budget's episodes, evaluation and chunks set, on seeds 0-14; nothing
    of the quick preset or of ``extended`` leaks in."""
    ctx = Context(tmp_path, scale="paper", variant=variant)
    for algo in ("ddpg", "hi-ddpg", "hi-ddpg-wo-model", "h-ddpg"):
        for task in ("PuckTrajectory2", "PuckObstacle", "ArmObstacle"):
            cfg = ctx.config(algo, task)
            want = make_config(algo, task, variant,
                               ["eval_every=20", "chunk_episodes=250"])
            assert cfg == want and cfg.episodes == 3000 and cfg.preset == variant
            assert ctx.seed_list(task) == list(range(15))
    assert ctx.note().startswith(f"variant {variant}: the paper")


def test_unknown_variant_is_refused(tmp_path, capsys):
    with pytest.raises(ValueError, match="variant='huge' must be one of"):
        Context(tmp_path, variant="huge")
    assert reproduce.main(["fig4", "--variant", "huge"]) == 2
    assert "invalid choice: 'huge'" in capsys.readouterr().err
