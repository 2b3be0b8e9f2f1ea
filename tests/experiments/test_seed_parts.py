"""Seed parts (``hiddpg reproduce --part``): a run trained part by part gives the artifact and
the figure numbers of the same run trained whole; parts that do not fit are refused before
anything is trained or written.

One tiny figure (Fig. 3 from 2 seeds x 20 episodes): trained whole into one output, and as
the parts ``--part 1`` then ``--part 0`` into another.
"""

from __future__ import annotations

import json
import re
import shutil

import pytest
from tiny_output import TINY

from hiddpg.commands import report as report_cmd
from hiddpg.commands import reproduce
from hiddpg.experiments.artifacts import EVALUATIONS_FILE, SNAPSHOTS_FILE, TRAINING_FILE
from hiddpg.experiments.common import Context
from hiddpg.experiments.parts import merge_parts, part_label
from hiddpg.machine import describe, machine_text
from hiddpg.runner import seed_ranges

# a seed computes bit for bit the same in a part as in the whole run at XLA's default build;
# CI's lowered level rounds a one-seed and a two-seed program apart (tests/conftest.py)
pytestmark = pytest.mark.xla_optimized
RUN = "hi-ddpg-PuckTrajectory2"


def _fig3(out, *extra):
    return reproduce.main(["fig3", "--out", str(out), *TINY, *extra])


def _numbers(out):
    return json.loads((out / "sections" / "fig3.json").read_text())["numbers"]


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    whole, parted = tmp_path_factory.mktemp("whole"), tmp_path_factory.mktemp("parted")
    assert _fig3(whole) == 0
    assert _fig3(parted, "--part", "1") == 0
    after_one = {"meta": json.loads((parted / "artifacts" / RUN / "meta.json").read_text()),
                 "numbers": _numbers(parted), "report": (parted / "report.md").read_text()}
    assert _fig3(parted, "--part", "0") == 0
    return whole, parted, after_one


def test_labels_name_the_seed_ranges():
    assert part_label([4, 0, 1, 2, 3, 7]) == "seeds-0-4_7"
    assert seed_ranges([5]) == ["5"]


def test_one_part_is_drawn_with_its_own_seeds(outputs):
    whole, parted, one = outputs
    assert one["meta"]["seeds"] == [1]
    assert [p["part"] for p in one["meta"]["parts"]] == ["seeds-1"]
    assert "| hi-ddpg-PuckTrajectory2 | 1 | 20 | finished | seeds-1 |" in one["report"]
    assert one["numbers"] != _numbers(whole)  # one seed of two: other statistics
    assert one["numbers"]["seeds"] == [1]
    assert re.search(r"^\| 1 \| 1 \| -?\d", one["report"], re.M)  # runs, seeds, return


def test_the_parts_merge_into_the_whole_run_s_artifact(outputs):
    whole, parted, _ = outputs
    a, b = whole / "artifacts" / RUN, parted / "artifacts" / RUN
    for name in (EVALUATIONS_FILE, TRAINING_FILE, SNAPSHOTS_FILE):
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    config_a, config_b = (json.loads((p / "config.json").read_text()) for p in (a, b))
    assert config_b["config"] == config_a["config"] and config_b["seeds"] == [0, 1]
    meta_a, meta_b = (json.loads((p / "meta.json").read_text()) for p in (a, b))
    assert meta_b["seeds"] == [0, 1] and meta_b["status"] == "finished"
    assert [(p["part"], p["seeds"]) for p in meta_b["parts"]] == [("seeds-0", [0]),
                                                                  ("seeds-1", [1])]
    assert meta_b["wall_time"] == pytest.approx(sum(p["wall_time"] for p in meta_b["parts"]))
    assert {k: v for k, v in meta_b.items() if k not in ("parts", "wall_time", "files")} == {
        k: v for k, v in meta_a.items() if k not in ("wall_time", "files", "machines")}
    # each part keeps the machine that trained it and its seconds (hiddpg.machine)
    for part in meta_b["parts"]:
        assert [(s["machine"], s["episodes"], s["wall_time"]) for s in part["machines"]] == [
            (describe(), [0, 20], part["wall_time"])]
    assert _numbers(parted) == _numbers(whole)
    assert sorted(p.name for p in (parted / "runs").iterdir()) == [f"{RUN}.seeds-0",
                                                                   f"{RUN}.seeds-1"]


def test_report_redraws_a_merged_output_from_its_artifacts(outputs, tmp_path):
    whole, parted, _ = outputs
    out = tmp_path / "out"
    shutil.copytree(parted / "artifacts", out / "artifacts")
    assert report_cmd.main([str(out), "fig3"]) == 0
    assert _numbers(out) == _numbers(whole)
    report = (out / "report.md").read_text()
    assert "| hi-ddpg-PuckTrajectory2 | 0-1 | 20 | finished | seeds-0, seeds-1 |" in report
    assert re.search(r"^\| 2 \| 0-1 \| -?\d", report, re.M)  # Fig. 3's runs and seeds
    where = report.split("## Where the runs trained")[1].split("##")[0]
    for seed in (0, 1):
        assert f"| {RUN} | {seed} | 1-20 | {machine_text(describe())} | " in where
    # what is left: nothing of this run; the puck's (never run) at this run's rate
    left = report.split("## Still to train")[1]
    assert "| hi-ddpg on PuckTrajectory2 | 2 | 0-1 | 0 | 0 |" in left
    assert re.search(r"\| hi-ddpg on PuckObstacle \| 2 \| - \| 2,000 \| (< 0\.1|\d+\.\d) "
                     r"\(rate of hi-ddpg on other tasks\) \|", left), left


def test_parts_that_do_not_fit_are_refused_before_training(outputs, capsys):
    whole, parted, _ = outputs
    before = (parted / "artifacts" / RUN / "meta.json").read_bytes()
    assert _fig3(parted, "--seeds", "3", "--part", "1-2") == 1  # seed 1 is in a part already
    assert ("seed(s) [1] of --part 1-2 are in other parts already (seeds-1 in"
            in capsys.readouterr().err)
    assert _fig3(parted, "--seeds", "3") == 1  # a whole run of 3 seeds over parts of 2
    assert ("is merged from parts and holds seeds 0-1 of 0-2; train the others with --part"
            in capsys.readouterr().err)
    assert _fig3(whole, "--seeds", "3", "--part", "2") == 1  # a part beside a whole run
    assert "is the artifact of a whole run, not of parts" in capsys.readouterr().err
    assert _fig3(parted, "--set", "agent.high.tau=0.5") == 1
    assert "holds a run with another config (agent)" in capsys.readouterr().err
    assert (parted / "artifacts" / RUN / "meta.json").read_bytes() == before
    assert not (whole / "parts").exists()
    assert sorted(p.name for p in (parted / "runs").iterdir()) == [f"{RUN}.seeds-0",
                                                                   f"{RUN}.seeds-1"]


def test_an_artifact_that_holds_the_seeds_is_reused_without_its_run(outputs, tmp_path,
                                                                      capsys):
    """A committed output (artifacts, no run directories) is not trained again: with or without
    --part, whole or merged, wherever its seeds are all there."""
    whole, parted, _ = outputs
    for source, extra in ((whole, ()), (parted, ()), (whole, ("--part", "1")),
                          (parted, ("--part", "0"))):
        out = tmp_path / f"{source.name}{len(extra)}"
        shutil.copytree(source / "artifacts", out / "artifacts")
        assert _fig3(out, *extra) == 0
        assert "finished, reused (seeds " in capsys.readouterr().err
        assert not (out / "runs").exists() and not (out / "parts").exists()
        assert _numbers(out) == _numbers(whole)
        # the report's training time is the artifact's (the parts' sum), with no run on disk
        wall = json.loads((source / "artifacts" / RUN / "meta.json").read_text())["wall_time"]
        assert f"| training {RUN} (all invocations) | {wall:.1f} |" in (
            out / "report.md").read_text()


@pytest.mark.parametrize("part, says", [("2", "part=[2] must be seeds of the runs' 0..1"),
                                        ("1-0", "range '1-0' is empty"),
                                        ("x", "'x' is not a seed")])
def test_bad_parts_exit_2_naming_the_value(part, says, tmp_path, capsys):
    assert _fig3(tmp_path / "out", "--part", part) == 2
    err = capsys.readouterr().err
    assert says in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()


def test_merging_refuses_parts_of_other_configs(outputs, tmp_path):
    whole, parted, _ = outputs
    folder = tmp_path / "parts"
    shutil.copytree(parted / "parts" / RUN / "seeds-0", folder / "seeds-0")
    shutil.copytree(parted / "parts" / RUN / "seeds-1", folder / "seeds-1")
    config = json.loads((folder / "seeds-1" / "config.json").read_text())
    config["config"]["episodes"] = 21
    (folder / "seeds-1" / "config.json").write_text(json.dumps(config))
    with pytest.raises(Exception, match="have other configs"):
        merge_parts(folder, tmp_path / "merged")
    assert not (tmp_path / "merged").exists()


def test_a_part_outside_the_runs_seeds_is_refused():
    with pytest.raises(ValueError, match=r"part=\[15\] must be seeds of the runs' 0..14"):
        Context("out", scale="paper", part=(15,))


def test_a_claim_on_fewer_seeds_than_planned_says_so(outputs):
    from hiddpg.experiments.claim_checks import Outcome, Output

    whole, parted, _ = outputs
    assert Output(parted).planned == 2  # --seeds 2, recorded in artifacts/reproduce.json
    assert Outcome("not reproduced", "0/1", seeds=[1], planned=2).cell() == (
        "**not reproduced**: 0/1; seeds 1 of 0-1 so far")
    assert Outcome("reproduced", "2/2", seeds=[0, 1], planned=2).cell() == (
        "**reproduced**: 2/2; seeds 0-1")
    assert Outcome("reproduced", "PT1 1/1, PT2 2/2", seeds=[0, 1], fewest=1, planned=2).cell() == (
        "**reproduced**: PT1 1/1, PT2 2/2; seeds 0-1, some runs on 1 of them so far")
    assert Output(parted).seeds("hi-ddpg", ["PuckTrajectory2", "PuckTrajectory1"]) == {
        "seeds": [0, 1], "fewest": 2}  # PuckTrajectory1 has no artifact there


def test_training_time_counts_each_run_once(tmp_path):
    """An artifact's time covers its parts' run directories; a run with no artifact yet (in
    progress) counts from its own directory, unless the report is drawn from artifacts."""
    from hiddpg.experiments.artifacts import META_FILE
    from hiddpg.experiments.report import training_wall_time
    from hiddpg.runs import PROGRESS_FILE

    files = {f"artifacts/{RUN}/{META_FILE}": {"wall_time": 30.0, "parts": [{"part": "seeds-0"}]},
             f"runs/{RUN}.seeds-0/{PROGRESS_FILE}": {"wall_time": 30.0},
             f"runs/{RUN}.seeds-1/{PROGRESS_FILE}": {"wall_time": 7.0}}
    for name, content in files.items():
        (tmp_path / name).parent.mkdir(parents=True)
        (tmp_path / name).write_text(json.dumps(content))
    assert training_wall_time(tmp_path) == {RUN: 30.0, f"{RUN}.seeds-1 (no artifact yet)": 7.0}
    assert training_wall_time(tmp_path, from_artifacts=True) == {RUN: 30.0}
