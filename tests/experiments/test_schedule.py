"""``hiddpg reproduce --dry-run``: which runs each figure needs, cheap ones first, and the
environment steps left, read from what is on disk."""

from __future__ import annotations

import pytest

from hiddpg.commands import reproduce
from hiddpg.experiments.common import Context
from hiddpg.experiments.schedule import CHEAP_FIRST, figure_runs, plan, plan_table
from hiddpg.runs import Run


def test_every_figure_needs_its_runs_and_arm_figures_come_last(tmp_path):
    ctx = Context(tmp_path, scale="paper", variant="paper")
    assert figure_runs(ctx, "fig3") == [("hi-ddpg", "PuckTrajectory2")]
    assert [t for _, t in figure_runs(ctx, "fig4")] == [
        "PuckTrajectory1", "PuckTrajectory2", "PuckTrajectory3"]
    assert {a for a, _ in figure_runs(ctx, "fig8")} == {
        "hi-ddpg", "h-ddpg", "hi-ddpg-wo-model", "ddpg"}
    assert set(CHEAP_FIRST) == set(reproduce.FIGURES) and CHEAP_FIRST[-2:] == ("fig6", "fig8")
    with pytest.raises(ValueError, match="unknown figure 'fig9'"):
        figure_runs(ctx, "fig9")


def test_plan_counts_each_shared_run_once_with_its_steps_left(tmp_path):
    ctx = Context(tmp_path, scale="paper", variant="paper")
    runs = plan(ctx, CHEAP_FIRST)
    assert len(runs) == 11  # 3 trajectory + 4 puck + 4 arm runs
    traj = next(r for r in runs if r.task == "PuckTrajectory2")
    assert traj.figures == ("fig3", "fig4", "fig5") and traj.status == "new"
    assert traj.steps_left == 15 * 3000 * 30
    arm = next(r for r in runs if (r.algo, r.task) == ("hi-ddpg", "ArmObstacle"))
    assert arm.figures == ("fig6", "fig8") and arm.steps_left == 15 * 3000 * 75
    table = plan_table(runs)
    assert table.splitlines()[-1] == f"| total | | | | | {sum(r.steps_left for r in runs):,} |"


def test_a_run_on_disk_is_planned_as_a_resume(tmp_path, capsys):
    ctx = Context(tmp_path, scale="quick", seeds=2, episodes=40)
    config = ctx.config("hi-ddpg", "PuckTrajectory2")
    Run.create(ctx.run_path("hi-ddpg", "PuckTrajectory2"), config, (0, 1)).close()
    (run,) = plan(ctx, ("fig3",))
    assert (run.status, run.done, run.steps_left) == ("resume", 0, 2 * 40 * 30)
    out = tmp_path / "o"
    assert reproduce.main(["all", "--dry-run", "--out", str(out), "--seeds", "2"]) == 0
    text = capsys.readouterr().out
    assert "variant quick" in text and "nothing is trained" in text
    assert not out.exists()  # a dry run writes nothing


def _meta(ctx, algo, task, seeds, episodes, wall_time, status="finished"):
    import json

    from hiddpg.experiments.artifacts import ARTIFACT_FORMAT, META_FILE

    path = ctx.artifact_path(algo, task)
    path.mkdir(parents=True)
    (path / META_FILE).write_text(json.dumps({
        "format": ARTIFACT_FORMAT, "seeds": seeds, "episodes": episodes,
        "wall_time": wall_time, "status": status}))


def test_what_is_left_is_counted_from_the_artifacts_at_the_output_s_own_rate(tmp_path):
    """PT2 whole (3 h for 15 x 3000 x 30 steps: 125 steps/s), PT1 seeds 0-4 (1 h for
    5 x 3000 x 30: 125 steps/s), PT3 unfinished, the arm's HI-DDPG seeds 0-4 at 50 steps/s:
    each run's rest at its own rate; PT3, with none of its own, at HI-DDPG's other runs'
    (their steps over their seconds, about 79 steps/s); DDPG, with no run, at all runs'."""
    from hiddpg.experiments.schedule import left, left_table

    ctx = Context(tmp_path, scale="paper", variant="paper")
    _meta(ctx, "hi-ddpg", "PuckTrajectory2", list(range(15)), 3000, 3 * 3600.0)
    _meta(ctx, "hi-ddpg", "PuckTrajectory1", list(range(5)), 3000, 3600.0)
    _meta(ctx, "hi-ddpg", "PuckTrajectory3", list(range(15)), 1000, 900.0, status="running")
    _meta(ctx, "hi-ddpg", "ArmObstacle", list(range(5)), 3000, 5 * 3000 * 75 / 50)
    runs = {(r.algo, r.task): r for r in left(ctx)}
    assert len(runs) == 11
    assert runs["hi-ddpg", "PuckTrajectory2"].steps_left == 0
    pt1 = runs["hi-ddpg", "PuckTrajectory1"]
    assert pt1.held == tuple(range(5)) and pt1.steps_left == 10 * 3000 * 30
    assert pt1.hours == pytest.approx(2.0) and pt1.rate_of == "run"
    pt3 = runs["hi-ddpg", "PuckTrajectory3"]  # an unfinished artifact holds nothing yet
    rate = (20 * 3000 * 30 + 5 * 3000 * 75) / (4 * 3600 + 5 * 3000 * 75 / 50)
    assert pt3.held == () and pt3.rate_of == "hi-ddpg"
    assert pt3.hours == pytest.approx(15 * 3000 * 30 / rate / 3600)
    arm = runs["hi-ddpg", "ArmObstacle"]
    assert arm.rate_of == "run" and arm.hours == pytest.approx(10 * 3000 * 75 / 50 / 3600)
    ddpg = runs["ddpg", "ArmObstacle"]
    assert ddpg.rate_of == "all" and ddpg.hours == pytest.approx(15 * 3000 * 75 / rate / 3600)
    table = left_table(list(runs.values())).splitlines()
    assert "| hi-ddpg on PuckTrajectory1 | 15 | 0-4 | 900,000 | 2.0 |" in table
    assert "| hi-ddpg on PuckTrajectory3 | 15 | - | 1,350,000 | 4.7 (rate of hi-ddpg on other " \
        "tasks) |" in table
    assert "| ddpg on ArmObstacle | 15 | - | 3,375,000 | 11.8 (rate of all runs) |" in table
    assert table[-1].startswith(f"| total | | | {sum(r.steps_left for r in runs.values()):,} |")
    # an output with nothing finished has no rate; one with everything finished has nothing left
    fresh = left(Context(tmp_path / "fresh", scale="paper", variant="paper"))
    assert all(r.hours is None for r in fresh) and left_table(fresh).splitlines()[-1].endswith(
        " | - |")
    done = [r.__class__(r.algo, r.task, r.planned, tuple(range(15)), 0, 0.0, r.algo)
            for r in fresh]
    assert left_table(done) == "Nothing: every run holds the seeds it is meant to."


def test_a_redraw_from_some_trajectory_tasks_still_counts_the_others_as_left(tmp_path):
    """`hiddpg report` draws Figs. 4-5 from the trajectory tasks with an artifact (here PT2
    alone), but what is still to train keeps PT1 and PT3, which the output is meant to hold."""
    from hiddpg.experiments.redraw import artifact_context, write_context
    from hiddpg.experiments.schedule import left

    made = Context(tmp_path, scale="paper", variant="paper+")
    write_context(made)
    _meta(made, "hi-ddpg", "PuckTrajectory2", list(range(5)), 3000, 3600.0)
    ctx = artifact_context(tmp_path)
    assert figure_runs(ctx, "fig4") == [("hi-ddpg", "PuckTrajectory2")]
    runs = {(r.algo, r.task): r for r in left(ctx)}
    assert len(runs) == 11
    for task in ("PuckTrajectory1", "PuckTrajectory3"):
        assert runs["hi-ddpg", task].held == () and runs["hi-ddpg", task].steps_left == (
            15 * 3000 * 30)
    assert runs["hi-ddpg", "PuckTrajectory2"].steps_left == 10 * 3000 * 30
