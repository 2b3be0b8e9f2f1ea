"""``hiddpg train`` and ``hiddpg eval`` without surprises: path and name arguments checked
(one line, exit 2, nothing written), a bare ``train ALGO TASK`` that is short and says what it
costs, and a damaged checkpoint named instead of a traceback."""

from __future__ import annotations

import argparse
import json

import pytest

from hiddpg import runs
from hiddpg.commands import eval as eval_cmd
from hiddpg.commands import train as train_cmd

TINY = ["--set", "episodes=10", "--set", "eval_every=10", "--set", "chunk_episodes=10",
        "--set", "agent.hidden=[8,8]", "--set", "agent.learning_starts=50"]


def listing(path):
    return sorted(str(p.relative_to(path)) for p in path.rglob("*"))


@pytest.mark.parametrize("name", ["../escape", "a/b", "/abs", ".hidden", "-dash", "..", "a b",
                                  ""])
def test_name_cannot_leave_out(tmp_path, capsys, name):
    out = tmp_path / "out"
    code = train_cmd.main(["ddpg", "PuckTrajectory1", "--seeds", "0", *TINY,
                           "--out", str(out), f"--name={name}"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1, err
    assert f"--name {name!r}" in err and "one directory name" in err
    assert listing(tmp_path) == []  # nothing written, not even --out


def test_out_that_is_a_file(tmp_path, capsys):
    afile = tmp_path / "afile"
    afile.write_text("x")
    assert train_cmd.main(["ddpg", "PuckTrajectory1", "--seeds", "0", *TINY,
                           "--out", str(afile)]) == 2
    err = capsys.readouterr().err
    assert f"--out '{afile}' is a file; give a directory" in err and "Traceback" not in err
    assert afile.read_text() == "x"


@pytest.mark.parametrize("kind", ["file", "missing", "plain directory"])
def test_resume_of_something_that_is_not_a_run(tmp_path, capsys, kind):
    target = tmp_path / "target"
    if kind == "file":
        target.write_text("x")
    elif kind == "plain directory":
        target.mkdir()
    assert train_cmd.main(["--resume", str(target)]) == 2
    err = capsys.readouterr().err
    expected = {"file": "is a file, not a directory", "missing": "does not exist",
                "plain directory": "is not a run directory (no config.json)"}[kind]
    assert f"--resume '{target}'" in err and expected in err and err.count("\n") == 1


def test_bare_train_is_the_quick_preset_on_five_seeds_and_says_what_it_costs(tmp_path, capsys):
    """Without --preset and --seeds: the quick preset on seeds 0-4 (the paper preset on 0-14),
    and the plan printed first. Only the preparation runs here (nothing is trained)."""
    args = train_cmd.build_parser().parse_args(["hi-ddpg", "PuckTrajectory1", "--out",
                                                str(tmp_path), "--name", "bare"])
    run, trainer = train_cmd._prepare(args)
    try:
        assert run.config.preset == "quick" and run.config.episodes == 1500
        assert run.seeds == (0, 1, 2, 3, 4)
    finally:
        run.close()
    paper = argparse.Namespace(**{**vars(args), "preset": "paper", "name": "paper"})
    run, _ = train_cmd._prepare(paper)
    run.close()
    assert run.config.preset == "paper" and run.seeds == tuple(range(15))
    plus = train_cmd.build_parser().parse_args(["hi-ddpg", "PuckTrajectory2", "--variant",
                                                "paper+", "--out", str(tmp_path), "--name", "p"])
    run, _ = train_cmd._prepare(plus)
    run.close()
    assert run.config.preset == "paper+" and run.seeds == tuple(range(15))
    saved = json.loads((tmp_path / "p" / "config.json").read_text())
    assert saved["config"]["preset"] == "paper+"
    assert train_cmd.main(["ddpg", "PuckTrajectory1", "--seeds", "0", *TINY,
                           "--out", str(tmp_path), "--name", "tiny"]) == 0
    err = capsys.readouterr().err
    assert err.splitlines()[0].startswith("ddpg on PuckTrajectory1 (preset quick): 1 seed × 10 "
                                          "episodes")
    assert "environment steps" in err.splitlines()[0]


def test_eval_names_a_damaged_checkpoint(tmp_path, capsys):
    assert train_cmd.main(["ddpg", "PuckTrajectory1", "--seeds", "0", *TINY,
                           "--out", str(tmp_path), "--name", "r"]) == 0
    ckpt = tmp_path / "r" / runs.CHECKPOINT_FILE
    ckpt.write_bytes(b"\xff\xfegarbage that is not msgpack")
    capsys.readouterr()
    assert eval_cmd.main([str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert str(ckpt) in err and "is not a readable checkpoint" in err
    assert "Traceback" not in err and err.count("\n") == 1
