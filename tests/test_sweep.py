"""``hiddpg sweep`` on the local backend: spec expansion and names, validation messages,
skipping complete runs, resuming a half-done one, and finding run directories."""

from __future__ import annotations

import json
import os
import shutil

import pytest

from hiddpg import runs, sweep
from hiddpg.commands import sweep as sweep_cmd
from hiddpg.commands import train as train_cmd

ONE_RUN = """
algos = "ddpg"
tasks = "PuckTrajectory1"
seeds = "0-1"
presets = "quick"
[set]
episodes = 20
eval_every = 10
chunk_episodes = 10
agent.hidden = [16, 16]
agent.learning_starts = 50
"""


class Crash(RuntimeError):
    pass


def write(tmp_path, text, name="sweep.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def names(spec):
    return [r.name for r in sweep.expand(spec)]


# -- expansion --------------------------------------------------------------------------------
def test_expansion_counts_and_order():
    spec = {"algos": ["ddpg", "hi-ddpg"], "tasks": ["PuckTrajectory1", "PuckTrajectory2"],
            "presets": "quick", "seeds": [3, 5],
            "set": {"episodes": 20}, "grid": {"agent": {"learning_starts": [50, 100, 200]}}}
    runs_ = sweep.expand(spec)
    assert len(runs_) == 2 * 2 * 3
    assert [(r.algo, r.task) for r in runs_[:4]] == [("ddpg", "PuckTrajectory1")] * 3 + [
        ("ddpg", "PuckTrajectory2")]
    first = runs_[0]
    assert first.seeds == (3, 5) and first.preset == "quick"
    assert first.sets == ("episodes=20", "agent.learning_starts=50")
    assert first.grid == (("agent.learning_starts", 50),)
    assert first.config.episodes == 20 and first.config.agent.learning_starts == 50
    assert first.name.startswith("ddpg-PuckTrajectory1-quick-agent.learning_starts=50-")
    assert len({r.name for r in runs_}) == len(runs_)
    # two grid axes multiply; a spec without a grid is one run per (algo, task, preset)
    two = dict(spec, algos="ddpg", tasks="PuckTrajectory1",
               grid={"agent.tau": [0.01, 0.005], "agent.hidden": [[16, 16], [8, 8]]})
    assert len(sweep.expand(two)) == 4
    assert len(sweep.expand(dict(spec, grid={}))) == 4
    assert sweep.expand({"algos": "ddpg", "tasks": "PuckTrajectory1"})[0].seeds == tuple(
        range(15))


def test_groups_inherit_replace_extend_and_dedupe():
    spec = {"tasks": "PuckTrajectory1", "presets": "quick", "seeds": "0-1",
            "set": ["episodes=20"], "grid": {"episodes": [10, 20]},
            "group": [{"algos": "ddpg", "grid": {"agent.tau": [0.01, 0.02]}},
                      {"algos": "hi-ddpg", "seeds": "0-2", "set": ["agent.high.tau=0.05"]},
                      {"algos": "ddpg", "grid": {"agent.tau": [0.01]}}]}  # duplicates group 1
    runs_ = sweep.expand(spec)
    ddpg = [r for r in runs_ if r.algo == "ddpg"]
    hi = [r for r in runs_ if r.algo == "hi-ddpg"]
    assert len(ddpg) == 4 and len(hi) == 2 and len(runs_) == 6
    assert {r.config.episodes for r in hi} == {10, 20} and hi[0].seeds == (0, 1, 2)
    assert all(r.config.agent.high.tau == 0.05 for r in hi)
    assert ddpg[0].seeds == (0, 1)


def test_a_group_with_an_earlier_config_on_other_seeds_is_a_run_of_its_own():
    """Groups that differ only in their seeds are two runs, none dropped; the first keeps the
    plain name, so appending such a group renames no existing run."""
    base = {"algos": "ddpg", "tasks": "PuckTrajectory1", "presets": "quick",
            "set": ["episodes=20"]}
    first = sweep.expand(dict(base, seeds="100-104"))[0]
    runs_ = sweep.expand(dict(base, group=[{"seeds": "100-104"}, {"seeds": "105-107,109"},
                                           {"seeds": "100-104"}, {"seeds": "105-107,109"}]))
    assert [r.seeds for r in runs_] == [(100, 101, 102, 103, 104), (105, 106, 107, 109)]
    assert runs_[0].name == first.name
    assert runs_[1].name == f"{first.name}-seeds-105-107_109"
    assert runs_[0].config == runs_[1].config


def test_names_are_deterministic_from_the_config():
    base = {"algos": "ddpg", "tasks": "PuckTrajectory1", "presets": "quick"}
    a = names(dict(base, grid={"agent.tau": [0.01]}))
    assert a == names(dict(base, grid={"agent.tau": [0.01]}))
    assert a[0] == sweep.run_name(sweep.expand(dict(base, set=["agent.tau=0.01"]))[0].config,
                                  (("agent.tau", 0.01),))
    assert a != names(dict(base, grid={"agent.tau": [0.02]}))
    # the hash covers the whole config, so fixed overrides change it too
    assert a[0][-8:] != names(dict(base, set=["episodes=5"], grid={"agent.tau": [0.01]}))[0][-8:]
    # seeds are not part of a config
    assert a == names(dict(base, seeds="0-2", grid={"agent.tau": [0.01]}))
    hidden = names(dict(base, grid={"agent.hidden": [[64, 64]]}))[0]
    assert "agent.hidden=64x64-" in hidden and "[" not in hidden and "/" not in hidden


def test_cli_flags_extend_the_spec(tmp_path, capsys):
    spec = write(tmp_path, ONE_RUN)
    argv = [str(spec), "--out", str(tmp_path / "out"), "--dry-run",
            "--tasks", "PuckTrajectory1,PuckTrajectory2", "--grid", "agent.tau=0.01,0.005",
            "--grid", "agent.hidden=[8,8],[4,4]", "--set", "agent.gamma=0.9"]
    assert sweep_cmd.main(argv) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 8 and [line.split()[:2] for line in lines] == [
        [str(i), "new"] for i in range(8)]
    assert "agent.tau=0.005-agent.hidden=4x4-" in lines[-1]
    assert not (tmp_path / "out").exists()  # a dry run writes nothing
    # --index picks one run (a Slurm array task)
    assert sweep_cmd.main(argv + ["--index", "7"]) == 0
    assert capsys.readouterr().out.split()[2] == lines[-1].split()[2]
    assert sweep_cmd.main(argv + ["--index", "8"]) == 2
    assert "--index 8 is out of range: the sweep has 8 runs, 0 to 7" in capsys.readouterr().err
    # flags alone, without a spec file
    assert sweep_cmd.main(["--out", str(tmp_path / "o"), "--dry-run", "--algos", "ddpg",
                           "--tasks", "PuckObstacle", "--grid", "agent.noise.kind=ou,gaussian"
                           ]) == 0
    assert len(capsys.readouterr().out.splitlines()) == 2


# -- bad specs ----------------------------------------------------------------------------------
@pytest.mark.parametrize("text,message", [
    ('algo = "ddpg"\ntasks = "PuckTrajectory1"', "unknown key 'algo' (did you mean 'algos'?)"),
    ('tasks = "PuckTrajectory1"', "algos is required"),
    ('algos = []\ntasks = "PuckTrajectory1"', "algos = [] must be a string or a non-empty"),
    ('algos = "ddpg"\ntasks = "PuckTrajectory1"\nseeds = "3-1"', "range '3-1' is empty"),
    ('algos = "ddpg"\ntasks = "PuckTrajectory1"\nseeds = [1, 1]', "has a seed twice"),
    ('algos = "ddpg"\ntasks = "PuckTrajectory1"\n[grid]\n"agent.tau" = 0.01',
     "grid.agent.tau = 0.01 must be a non-empty list of values, e.g. [0.01]"),
    ('algos = "ddpg"\ntasks = "PuckTrajectory1"\nset = ["episodes"]', "set = ['episodes']"),
    ('algos = "ddpg"\ntasks = "PuckTrajectory1"\n[[group]]\nalgos = "ddpg"\nseed = 1',
     "[[group]] 1: unknown key 'seed' (did you mean 'seeds'?)"),
    ('algos = "ddpg"\ntasks = "PuckTrajectory1"\n[[group]]\nset = 3',
     "[[group]] 1: set = 3 must be a table"),
    ('algos = "ddpg" tasks', "not valid TOML"),
])
def test_bad_spec_messages(tmp_path, capsys, text, message):
    spec = write(tmp_path, text)
    assert sweep_cmd.main([str(spec), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("hiddpg sweep: error: ") and message in err, err
    assert not (tmp_path / "out").exists()


def test_bad_runs_are_named_before_anything_runs(tmp_path, capsys):
    spec = write(tmp_path, """
algos = ["ddpg", "hi-ddpg"]
tasks = ["PuckTrajectory1", "Nowhere"]
presets = "quick"
[grid]
"agent.tau" = [0.01, 2.0]
"env.no_such_param" = [1]
""")
    assert sweep_cmd.main([str(spec), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "8 of 8 runs are invalid" in err
    assert ("run 2 (ddpg PuckTrajectory1 preset quick, agent.tau=2.0, env.no_such_param=1): "
            "DDPGConfig.tau=2.0 must lie in [0, 1]") in err
    assert ("run 1 (ddpg PuckTrajectory1 preset quick, agent.tau=0.01, env.no_such_param=1): "
            "unknown parameter(s) ['no_such_param']") in err
    assert "run 3 (ddpg Nowhere preset quick, agent.tau=0.01, env.no_such_param=1) and 3 " \
        "more: unknown task 'Nowhere'" in err
    assert "unknown key 'tau' in HIDDPGConfig" in err
    assert not (tmp_path / "out").exists()
    assert sweep_cmd.main(["--out", str(tmp_path / "o"), "--algos", "ddpg", "--tasks",
                           "PuckTrajectory1", "--address", "auto"]) == 2
    assert "--address needs --backend ray" in capsys.readouterr().err


# -- running, skipping, resuming ----------------------------------------------------------------
@pytest.fixture(scope="module")
def done(tmp_path_factory):
    """A one-run sweep trained to the end in this process: (spec, out, run)."""
    tmp = tmp_path_factory.mktemp("sweep")
    spec = write(tmp, ONE_RUN)
    out = tmp / "out"
    assert sweep_cmd.main([str(spec), "--out", str(out)]) == 0
    (run,) = sweep.expand(sweep.load_spec(spec))
    return spec, out, run


def test_a_sweep_run_is_a_train_run(done, capsys):
    spec, out, run = done
    assert sweep.is_finished(out / run.name, 20)
    opened = runs.Run.open(out / run.name)
    assert opened.config == run.config and opened.seeds == (0, 1)
    assert len(opened.read_metrics()) == 2 * 20
    manifest = json.loads((out / sweep.MANIFEST_FILE).read_text())["runs"]
    assert manifest[run.name]["algo"] == "ddpg" and manifest[run.name]["seeds"] == [0, 1]
    attempts = json.loads((out / sweep.SWEEP_DIR / "attempts" / f"{run.name}.json").read_text())
    assert [a["start_episode"] for a in attempts] == [0]


def test_complete_runs_are_skipped(done, capsys):
    spec, out, run = done
    before = {f: (out / run.name / f).read_bytes() for f in os.listdir(out / run.name)
              if os.path.isfile(out / run.name / f)}
    assert sweep_cmd.main([str(spec), "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert "1 complete (skipped), 0 to resume, 0 new" in captured.err
    assert f"ok      {run.name}  final eval return " in captured.out
    after = {f: (out / run.name / f).read_bytes() for f in before}
    assert after == before
    assert sweep_cmd.main([str(spec), "--out", str(out), "--dry-run"]) == 0
    assert capsys.readouterr().out.split()[:2] == ["0", "finished"]


def test_half_done_run_is_resumed(done, tmp_path, capsys):
    """A run crashed after its first chunk is resumed from its checkpoint (here with
    ``--workers 2``: in a subprocess) and ends as if it had never stopped."""
    spec, ref_out, run = done
    out = tmp_path / "out"

    def crash(_run, episodes):
        if episodes == 10:
            raise Crash

    with pytest.raises(Crash):
        train_cmd.main(run.train_argv(out), on_chunk=crash)
    assert sweep.run_state(out, run) == sweep.RESUME
    assert sweep_cmd.main([str(spec), "--out", str(out), "--workers", "2"]) == 0
    assert "0 complete (skipped), 1 to resume, 0 new" in capsys.readouterr().err
    for f in (runs.METRICS_FILE, runs.CHECKPOINT_FILE):
        assert (out / run.name / f).read_bytes() == (ref_out / run.name / f).read_bytes()
    attempts = json.loads((out / sweep.SWEEP_DIR / "attempts" / f"{run.name}.json").read_text())
    assert [a["start_episode"] for a in attempts] == [10]
    log = (out / sweep.SWEEP_DIR / "logs" / f"{run.name}.log").read_text()
    assert "resuming" in log and "at episode 10" in log


def test_mismatching_run_directories_stop_the_sweep(done, tmp_path, capsys):
    spec, ref_out, run = done
    out = tmp_path / "out"
    shutil.copytree(ref_out, out)
    other = write(tmp_path, ONE_RUN.replace('seeds = "0-1"', 'seeds = "0-2"'), "other.toml")
    assert sweep_cmd.main([str(other), "--out", str(out)]) == 2
    assert "was trained on seeds [0, 1], the spec asks for [0, 1, 2]" in capsys.readouterr().err
    shutil.rmtree(out / run.name)
    (out / run.name).mkdir()
    (out / run.name / "notes.txt").write_text("mine")
    assert sweep_cmd.main([str(spec), "--out", str(out)]) == 2
    assert "is not a run directory" in capsys.readouterr().err
    # a directory left by a run killed inside Run.create (temporary files only) is redone
    (out / run.name / "notes.txt").unlink()
    (out / run.name / ".config.json.x.tmp").write_text("")
    assert sweep.run_state(out, run) == sweep.NEW


def test_find_runs(done, tmp_path):
    _, ref_out, run = done
    assert sweep.find_runs(ref_out) == [ref_out / run.name]
    assert sweep.find_runs(ref_out / run.name) == [ref_out / run.name]
    nested = tmp_path / "all"
    shutil.copytree(ref_out, nested / "sweep_a")
    shutil.copytree(ref_out / run.name, nested / "b" / "c" / "single")
    shutil.copytree(ref_out / run.name, nested / ".hidden" / "x")
    (nested / "empty").mkdir()
    assert sweep.find_runs(nested) == [nested / "b" / "c" / "single",
                                       nested / "sweep_a" / run.name]
    assert sweep.find_runs(tmp_path / "missing") == []


def test_a_failing_run_does_not_stop_the_sweep(tmp_path, monkeypatch, capsys):
    calls = []

    def broken_train(argv, on_chunk=None):
        calls.append(argv)
        raise RuntimeError("XLA ran out of memory")

    monkeypatch.setattr(train_cmd, "main", broken_train)
    argv = ["--out", str(tmp_path / "out"), "--algos", "ddpg", "--presets", "quick",
            "--tasks", "PuckTrajectory1,PuckTrajectory2", "--seeds", "0"]
    assert sweep_cmd.main(argv) == 1
    assert len(calls) == 2
    captured = capsys.readouterr()
    assert captured.out.count("FAILED  ") == 2
    assert "RuntimeError: XLA ran out of memory" in captured.out


def test_run_names_hash_only_values_that_differ_from_their_defaults():
    """A field added to a config class at its default must not rename existing runs: the hash
    covers only non-default values."""
    from hiddpg.presets import make_config
    from hiddpg.sweep_spec import _non_defaults, config_hash

    plain = make_config("hi-ddpg", "PuckTrajectory2", "paper")
    pruned = _non_defaults(plain)
    # the paper's puck high level is LevelConfig's own default: it is left out entirely
    assert "actor_output" not in pruned["agent"].get("high", {})
    assert "model_masked" not in pruned["agent"]  # True is its default
    assert "low" not in pruned["agent"]  # likewise the low level
    arm = _non_defaults(make_config("hi-ddpg", "ArmObstacle", "paper"))["agent"]["low"]
    assert arm["lr"] == 5e-4 and "gamma" not in arm
    linear = make_config("hi-ddpg", "PuckTrajectory2", "paper",
                         ["agent.high.actor_output=linear"])
    assert _non_defaults(linear)["agent"]["high"]["actor_output"] == "linear"
    assert config_hash(linear) != config_hash(plain)
    assert config_hash(make_config("hi-ddpg", "PuckTrajectory2", "paper",
                                   ["agent.high.actor_output=tanh"])) == config_hash(plain)
