"""``hiddpg reproduce --algos``: a comparison figure's methods trained one invocation at a
time; each invocation trains only its algorithms and draws the others from their artifacts.

One tiny Fig. 7 (2 seeds x 20 episodes): DDPG alone first, then HI-DDPG alone.
"""

from __future__ import annotations

import json

import pytest

from hiddpg.commands import reproduce

TINY = ["--seeds", "2", "--episodes", "20", "--set", "agent.hidden=[16,16]"]


def _fig7(out, *extra):
    return reproduce.main(["fig7", "--out", str(out), *TINY, *extra])


def _section(out):
    return json.loads((out / "sections" / "fig7.json").read_text())


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    out = tmp_path_factory.mktemp("fig7")
    assert _fig7(out, "--algos", "ddpg") == 0
    first = _section(out)
    ddpg_files = {p.name: p.read_bytes() for p in (out / "artifacts" / "ddpg-PuckObstacle")
                  .iterdir() if p.is_file()}
    assert _fig7(out, "--algos", "hi-ddpg") == 0
    return out, first, ddpg_files


def test_first_invocation_trains_and_draws_only_its_algorithm(outputs):
    _, first, _ = outputs
    assert list(first["runs"]) == ["DDPG"]
    assert first["numbers"]["final"]["DDPG"]["n"] == 2
    assert first["numbers"]["seeds"] == {"DDPG": [0, 1]}
    assert "| DDPG | 2 | 0-1 |" in first["markdown"]  # each method's seeds beside its numbers
    for other in ("hi-ddpg", "h-ddpg", "hi-ddpg-wo-model"):
        assert f"{other} is not available and was left out (not trained here (--algos ddpg)" \
            in first["markdown"]


def test_second_invocation_draws_the_first_from_its_artifact_untouched(outputs):
    out, _, ddpg_files = outputs
    second = _section(out)
    assert list(second["runs"]) == ["HI-DDPG", "DDPG"]
    assert second["runs"]["DDPG"] == "artifacts/ddpg-PuckObstacle"
    assert [(p["a"], p["b"]) for p in second["numbers"]["pairs"]] == [("HI-DDPG", "DDPG")]
    now = {p.name: p.read_bytes() for p in (out / "artifacts" / "ddpg-PuckObstacle").iterdir()
           if p.is_file()}
    assert now == ddpg_files
    assert sorted(p.name for p in (out / "runs").iterdir()) == ["ddpg-PuckObstacle",
                                                                "hi-ddpg-PuckObstacle"]


def test_dry_run_lists_only_the_algorithms_it_trains(outputs, capsys):
    out, _, _ = outputs
    capsys.readouterr()
    assert _fig7(out, "--algos", "h-ddpg,ddpg", "--dry-run") == 0
    table = capsys.readouterr().out
    assert "| h-ddpg on PuckObstacle |" in table and "| ddpg on PuckObstacle |" in table
    assert "| hi-ddpg on PuckObstacle |" not in table


@pytest.mark.parametrize("algos", ["ddgp", "", "hi-ddpg,sac"])
def test_unknown_algorithms_exit_2_naming_the_value(algos, tmp_path, capsys):
    assert _fig7(tmp_path / "out", "--algos", algos) == 2
    err = capsys.readouterr().err
    assert "must be one or more of" in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()


def test_all_passes_over_figures_it_trains_nothing_of_and_cannot_draw(outputs, capsys):
    out, _, _ = outputs
    capsys.readouterr()
    assert reproduce.main(["all", "--out", str(out), *TINY, "--algos", "ddpg",
                           "--dry-run"]) == 0
    printed = capsys.readouterr().out
    for figure, algo, task in [("fig3", "hi-ddpg", "PuckTrajectory2"),
                               ("fig6", "hi-ddpg", "ArmObstacle")]:
        assert (f"{figure} passed over: --algos ddpg trains none of its runs and {algo} on "
                f"{task} has no artifact") in printed
    assert "fig7 passed over" not in printed and "fig8 passed over" not in printed
    table = printed[printed.index("| run |"):]
    assert "| ddpg on PuckObstacle | fig7 |" in table and "| ddpg on ArmObstacle | fig8 |" in table
    assert "| hi-ddpg on" not in table


def test_a_figure_whose_artifacts_are_all_there_is_drawn(tmp_path):
    from hiddpg.experiments.artifacts import META_FILE
    from hiddpg.experiments.common import Context
    from hiddpg.experiments.schedule import not_drawn

    ctx = Context(out=str(tmp_path), scale="quick", variant="quick", algos=("ddpg",))
    assert not_drawn(ctx, "fig3").startswith("fig3 passed over: --algos ddpg")
    assert not_drawn(ctx, "fig7") is None  # it trains ddpg there
    artifact = ctx.artifact_path("hi-ddpg", "PuckTrajectory2")  # Fig. 3's task
    artifact.mkdir(parents=True)
    (artifact / META_FILE).write_text("{}")
    assert not_drawn(ctx, "fig3") is None
    assert not_drawn(Context(out=str(tmp_path), scale="quick", variant="quick"), "fig6") is None


def test_an_artifact_written_while_it_trains_is_drawn(outputs, tmp_path, monkeypatch):
    """Two invocations beside each other: the one that finishes last draws both methods,
    even though the other's artifact was not there when it started."""
    import shutil

    from hiddpg.experiments import comparison

    out = tmp_path / "out"
    shutil.copytree(outputs[0], out)
    hi = out / "artifacts" / "hi-ddpg-PuckObstacle"
    hidden = hi.rename(tmp_path / "hidden")
    real = comparison.ensure_run

    def ensure_run(ctx, algo, task):  # the other invocation finishes while ddpg's trains
        if algo == "ddpg" and not hi.exists():
            hidden.rename(hi)
        return real(ctx, algo, task)

    monkeypatch.setattr(comparison, "ensure_run", ensure_run)
    assert _fig7(out, "--algos", "ddpg") == 0
    section = _section(out)
    assert list(section["runs"]) == ["HI-DDPG", "DDPG"]
    assert "hi-ddpg is not available" not in section["markdown"]
