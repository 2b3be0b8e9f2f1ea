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
