"""The one-change-at-a-time table (hiddpg.experiments.diagnosis) from runs written with known
numbers: the last evaluation and the last-window training means, per run, named by the
changes sweep.json lists."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hiddpg.experiments import diagnosis
from hiddpg.presets import make_config
from hiddpg.runs import Run

SEEDS = (100, 101)


def write_run(path, shift: float):
    """40 episodes; env_return of seed i at episode e is shift + e / 10 + i; evaluations at
    episodes 20 and 40 return shift + episode + i."""
    run = Run.create(path, make_config("hi-ddpg", "PuckTrajectory2", "paper"), SEEDS)
    episodes = np.tile(np.arange(1, 41), (2, 1))
    seed_offset = np.array([[0.0], [1.0]])
    train = {"episode": episodes, "env_return": shift + episodes / 10 + seed_offset,
             "return": shift - 5 + episodes * 0.0 + seed_offset, "length": np.full((2, 40), 30),
             "reach_error": np.full((2, 40), 0.25), "switches": np.ones((2, 40))}
    evals = {"episode": np.array([[20, 40], [20, 40]]),
             "env_return": shift + np.array([[20.0, 40.0], [21.0, 41.0]]),
             "switches": np.array([[1.0, 2.0], [1.0, 4.0]])}
    run.append_metrics(train, evals)
    run.close()


def test_rows_hold_the_last_evaluation_and_the_last_window(tmp_path):
    write_run(tmp_path / "a", 0.0)
    write_run(tmp_path / "b", -100.0)
    (tmp_path / "sweep.json").write_text(json.dumps({"runs": {
        "a": {"preset": "paper", "sets": []},
        "b": {"preset": "paper", "sets": ["agent.high.lr=0.0001", "agent.low.lr=0.001"]}}}))
    rows = diagnosis.summarize([str(tmp_path)], window=10)
    assert [r["run"] for r in rows] == ["paper", "agent.high.lr=0.0001, agent.low.lr=0.001"]
    a, b = rows
    assert a["episodes"] == 40 and a["seeds"] == 2
    assert a["eval_env_return"] == pytest.approx((40.5, np.std([40, 41], ddof=1)))
    assert b["eval_env_return"][0] == pytest.approx(-59.5)
    assert a["eval_switches"] == pytest.approx((3.0, np.std([2, 4], ddof=1)))
    # last 10 episodes: e = 31..40, mean e / 10 = 3.55; seeds 3.55 and 4.55
    assert a["env_return"] == pytest.approx((4.05, np.std([3.55, 4.55], ddof=1)))
    assert a["reach_error"] == pytest.approx((0.25, 0.0))
    assert "high_q_mean" not in a
    table = diagnosis.markdown(rows).splitlines()
    assert table[0].startswith("| run | episodes | seeds | score | vs_paper | eval_env_return")
    assert "high_q_mean" not in table[0]
    # score: the mean of the (two) evaluations per seed: 30 and 31; paper has no vs_paper
    assert table[2].startswith("| paper | 40 | 2 | 30.5 ± 0.71 |  | 40.5 ± 0.71 |")
    assert a["score"] == pytest.approx((30.5, np.std([30, 31], ddof=1)))
    # b is a shifted by -100 with the same spread: the difference is -100 with a zero-width
    # Welch interval only if the spread were 0; here t(df=2) * sqrt(0.5/2 + 0.5/2)
    diff, low, high = b["vs_paper"]
    half = 4.302652729911275 * np.sqrt(0.25 + 0.25)
    assert (diff, low, high) == pytest.approx((-100.0, -100.0 - half, -100.0 + half))
    # another run as the base: the paper run is compared with b, the other way round
    a2, b2 = diagnosis.summarize([str(tmp_path)], window=10, base=b["run"])
    assert "vs_base" not in b2 and "vs_paper" not in a2
    assert a2["vs_base"] == pytest.approx((100.0, 100.0 - half, 100.0 + half))
    assert diagnosis.markdown([a2, b2]).splitlines()[0].startswith(
        "| run | episodes | seeds | score | vs_base | eval_env_return")


def test_cut_compares_runs_at_the_same_budget_and_the_curves_are_drawn(tmp_path):
    write_run(tmp_path / "a", 0.0)
    (row,) = diagnosis.summarize([str(tmp_path / "a")], window=5, at=20)
    assert row["episodes"] == 20
    assert row["eval_env_return"] == pytest.approx((20.5, np.std([20, 21], ddof=1)))
    # last 5 episodes up to 20: e = 16..20, mean e/10 = 1.8 (seed 0) and 2.8 (seed 1)
    assert row["env_return"][0] == pytest.approx(2.3)
    with pytest.raises(ValueError, match="no episode <= 0"):
        diagnosis.summarize([str(tmp_path / "a")], at=0)
    out = diagnosis.plot_curves([str(tmp_path)], tmp_path / "c.png", at=30,
                                lines={"reference plan": 0.0})
    assert out.read_bytes().startswith(b"\x89PNG")


def test_an_exported_study_gives_the_same_table_without_the_runs(tmp_path):
    write_run(tmp_path / "runs" / "a", 0.0)
    write_run(tmp_path / "runs" / "b", -100.0)
    (tmp_path / "runs" / "sweep.json").write_text(json.dumps({"runs": {
        "a": {"preset": "paper", "sets": ["episodes=40"]},
        "b": {"preset": "paper", "sets": ["episodes=40", "agent.high.tau=0.01"]}}}))
    export, against_b = tmp_path / "study.json", tmp_path / "against-b.json"
    diagnosis.main([str(tmp_path / "runs"), "--window", "10", "--export", str(export)])
    b = "agent.high.tau=0.01"
    diagnosis.main([str(tmp_path / "runs"), "--window", "10", "--export", str(against_b),
                    "--base", b])
    direct = diagnosis.markdown(diagnosis.summarize([str(tmp_path / "runs")], window=10))
    direct_b = diagnosis.markdown(diagnosis.summarize([str(tmp_path / "runs")], 10, base=b))
    import shutil

    shutil.rmtree(tmp_path / "runs")
    again = diagnosis.markdown(diagnosis.summarize([str(export)]))
    assert again == direct
    # an export made with --base keeps it: its table compares with that run again
    assert "vs_base" in direct_b and diagnosis.markdown(
        diagnosis.summarize([str(against_b)])) == direct_b
    assert [r.split(" | ")[0] for r in direct.splitlines()[2:]] == [
        "| paper", "| agent.high.tau=0.01"]  # the budget is not a change


def test_a_run_without_a_finished_chunk_is_skipped_with_a_note(tmp_path, capsys):
    write_run(tmp_path / "a", 0.0)
    Run.create(tmp_path / "b", make_config("hi-ddpg", "PuckTrajectory2", "paper"), SEEDS).close()
    rows = diagnosis.summarize([str(tmp_path)])
    assert [r["episodes"] for r in rows] == [40]
    assert "skipped:" in capsys.readouterr().err


def test_the_command_names_a_bad_input_in_one_line(tmp_path, capsys):
    assert diagnosis.main([str(tmp_path / "nope")]) == 2
    assert diagnosis.main([str(tmp_path), "--line", "zero=abc"]) == 2
    write_run(tmp_path / "a", 0.0)
    assert diagnosis.main([str(tmp_path), "--base", "no such run"]) == 2
    captured = capsys.readouterr()
    err = captured.err.splitlines()
    assert len(err) == 3 and "nope is neither a run directory" in err[0]
    assert "--line 'zero=abc': expected LABEL=NUMBER" in err[1]
    assert "--base 'no such run': no run has this label; the runs are [" in err[2]
    assert not captured.out


def test_a_run_is_labelled_by_its_preset_unless_paper_then_its_changes(tmp_path):
    runs = {"a": {"preset": "paper", "sets": ["episodes=5"]},
            "b": {"preset": "paper", "sets": ["episodes=5", "agent.high.tau=0.01"]},
            "c": {"preset": "quick", "sets": ["episodes=5"]},
            "d": {"preset": "quick", "sets": ["agent.choice=actor"]}}
    (tmp_path / "sweep.json").write_text(json.dumps({"runs": runs}))
    labels = [diagnosis.changes(tmp_path / name) for name in ("a", "b", "c", "d", "e")]
    assert labels == ["paper", "agent.high.tau=0.01", "quick", "quick, agent.choice=actor", "e"]


def test_labels_name_runs_in_the_table_the_export_and_the_curves(tmp_path, capsys):
    write_run(tmp_path / "runs" / "a", 0.0)
    write_run(tmp_path / "runs" / "b", -100.0)
    (tmp_path / "runs" / "sweep.json").write_text(json.dumps({"runs": {
        "a": {"preset": "paper", "sets": ["agent.high.tau=0.01", "episodes=40"]},
        "b": {"preset": "paper", "sets": ["agent.high.tau=0.01", "agent.low.tau=0.01",
                                          "episodes=40", "agent.high.tau=0.001"]}}}))
    # a key the group sets again is listed once, with the value that holds
    assert (diagnosis.changes(tmp_path / "runs" / "b")
            == "agent.high.tau=0.001, agent.low.tau=0.01")
    export = tmp_path / "study.json"
    assert diagnosis.main([str(tmp_path / "runs"), "--window", "10", "--label", "a=candidate",
                           "--base", "candidate", "--export", str(export),
                           "--plot", str(tmp_path / "c.png")]) == 0
    table = capsys.readouterr().out
    assert "| candidate | 40 | 2 |" in table
    assert ("| agent.high.tau=0.001, agent.low.tau=0.01 | 40 | 2 | -69.5 ± 0.71 "
            "| -100 [-103, -97] |") in table
    assert [r["run"] for r in json.loads(export.read_text())["runs"]] == [
        "candidate", "agent.high.tau=0.001, agent.low.tau=0.01"]
    assert diagnosis.main([str(export)]) == 0 and capsys.readouterr().out in table
    # a name no run has, a malformed entry, a label for an export: one line each, exit 2
    assert diagnosis.main([str(tmp_path / "runs"), "--label", "c=x"]) == 2
    assert diagnosis.main([str(tmp_path / "runs"), "--label", "a"]) == 2
    assert diagnosis.main([str(export), "--label", "a=x"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 3
    assert "--label 'c': no run directory has this name; the runs are ['a', 'b']" in err[0]
    assert "--label 'a': expected NAME=LABEL" in err[1]
    assert "is an exported study; it keeps the labels it was exported with" in err[2]


def test_a_label_names_a_run_whose_name_holds_an_equals_sign():
    names = ["hi-ddpg-ArmObstacle-paper-agent.model_masked=false-bf7a88b5", "b"]
    got = diagnosis.parse_labels([f"{names[0]}=the term unmasked, x=1", "b=y=2"], names)
    assert got == {names[0]: "the term unmasked, x=1", "b": "y=2"}
    # an unknown name is the text before the first "=" (collect reports it); no label: an error
    assert diagnosis.parse_labels(["c=x=1"], names) == {"c": "x=1"}
    with pytest.raises(ValueError, match="expected NAME=LABEL"):
        diagnosis.parse_labels([f"{names[0]}="], names)


def test_runs_trained_later_are_added_to_an_exported_study(tmp_path, capsys):
    """An export plus new run directories: the export's records, then the new runs' (a label
    the export has is replaced); the table equals the one of all runs read together."""
    for name, shift in (("a", 0.0), ("b", -100.0), ("c", -50.0)):
        write_run(tmp_path / "runs" / name, shift)
    (tmp_path / "runs" / "sweep.json").write_text(json.dumps({"runs": {
        "a": {"preset": "paper", "sets": []},
        "b": {"preset": "paper", "sets": ["agent.high.tau=0.01"]},
        "c": {"preset": "paper", "sets": ["agent.low.tau=0.01"]}}}))
    together = diagnosis.markdown(diagnosis.summarize([str(tmp_path / "runs")], window=10))
    first = tmp_path / "first.json"
    diagnosis.main([str(tmp_path / "runs" / "a"), str(tmp_path / "runs" / "b"), "--window", "10",
                    "--export", str(first)])
    later = tmp_path / "later.json"
    diagnosis.main([str(first), str(tmp_path / "runs" / "c"), "--window", "10",
                    "--export", str(later)])
    assert diagnosis.markdown(diagnosis.summarize([str(later)])) == together
    assert [r["run"] for r in json.loads(later.read_text())["runs"]] == [
        "paper", "agent.high.tau=0.01", "agent.low.tau=0.01"]
    # b retrained (here: shifted) replaces b's record instead of adding a second one
    write_run(tmp_path / "again" / "b", -90.0)
    (tmp_path / "again" / "sweep.json").write_text(json.dumps({"runs": {
        "b": {"preset": "paper", "sets": ["agent.high.tau=0.01"]}}}))
    rows = diagnosis.summarize([str(later), str(tmp_path / "again")], window=10)
    assert [r["run"] for r in rows] == ["paper", "agent.low.tau=0.01", "agent.high.tau=0.01"]
    assert rows[2]["eval_env_return"][0] == pytest.approx(-49.5)
    # an export cut elsewhere is not mixed with runs cut at another episode
    capsys.readouterr()
    assert diagnosis.main([str(later), str(tmp_path / "again"), "--at", "20"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and "exported with at=None, not 20" in err[0]


def test_the_critic_error_is_its_start_value_minus_the_return_it_estimates(tmp_path):
    run = Run.create(tmp_path / "r", make_config("hi-ddpg", "PuckTrajectory2", "paper"), SEEDS)
    episodes = np.tile(np.arange(1, 41), (2, 1))
    train = {"episode": episodes, "env_return": np.zeros((2, 40)), "return": np.zeros((2, 40)),
             "length": np.full((2, 40), 30), "switches": np.ones((2, 40))}
    evals = {"episode": np.array([[20, 40], [20, 40]]), "env_return": np.zeros((2, 2)),
             "switches": np.ones((2, 2)),
             "high_q_start": np.array([[-10.0, -20.0], [-30.0, -30.0]]),
             "high_return_discounted": np.array([[-50.0, -40.0], [-30.0, -36.0]])}
    run.append_metrics(train, evals)
    run.close()
    (r,) = diagnosis.summarize([str(tmp_path)], window=10)
    # per seed, the mean over its evaluations of q - return: (40 + 20) / 2 = 30 and 3
    assert r["critic_error"] == pytest.approx((16.5, np.std([30.0, 3.0], ddof=1)))
    header = diagnosis.markdown([r]).splitlines()[0]
    assert "| eval_high_q_start | eval_high_return_discounted | critic_error |" in header


def test_only_draws_the_named_runs_in_that_order(tmp_path, capsys):
    from hiddpg.experiments.diagnosis_plot import curves

    write_run(tmp_path / "runs" / "a", 0.0)
    write_run(tmp_path / "runs" / "b", -100.0)
    (tmp_path / "runs" / "sweep.json").write_text(json.dumps({"runs": {
        "a": {"preset": "paper", "sets": []},
        "b": {"preset": "paper", "sets": ["agent.high.tau=0.01"]}}}))
    runs = [str(tmp_path / "runs")]
    assert [c["run"] for c in curves(runs)] == ["paper", "agent.high.tau=0.01"]
    (b, a) = curves(runs, only=["agent.high.tau=0.01", "paper"])
    assert (b["run"], a["run"]) == ("agent.high.tau=0.01", "paper")
    # seeds 100 and 101 evaluate shift + episode + i: means at 20 and 40, half 12.706 * 0.5
    assert list(a["episodes"]) == [20, 40]
    assert a["mean"] == pytest.approx([20.5, 40.5]) and b["mean"] == pytest.approx([-79.5, -59.5])
    assert a["half"] == pytest.approx([12.706204736 * 0.5] * 2)
    out = tmp_path / "only.png"
    assert diagnosis.main(runs + ["--plot", str(out), "--only", "paper"]) == 0
    assert out.read_bytes().startswith(b"\x89PNG")
    # the table keeps every run; a label no run has is one line naming the runs, exit 2
    assert "| agent.high.tau=0.01 |" in capsys.readouterr().out
    assert diagnosis.main(runs + ["--plot", str(out), "--only", "tau"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["python -m hiddpg.experiments.diagnosis: --only 'tau': no run with an "
                   "evaluation curve has this label; the runs are ['paper', "
                   "'agent.high.tau=0.01']"]
    # --only without a plot would choose nothing: one line, exit 2
    assert diagnosis.main(runs + ["--only", "paper"]) == 2
    assert "--only 'paper': chooses the runs drawn; give --plot" in capsys.readouterr().err
