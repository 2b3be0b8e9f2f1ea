"""Frames (shape, content, overlays), GIF writing and the ``hiddpg`` / ``hiddpg envs`` CLI."""

from __future__ import annotations

import re
import subprocess
import sys
import time

import jax
import numpy as np
import pytest
from PIL import Image

from hiddpg import cli, make, render
from hiddpg.commands import envs as envs_cmd
from hiddpg.envs import TASKS


@pytest.mark.parametrize("task", ["PuckTrajectory3", "PuckObstacle", "ArmReach", "ArmObstacle"])
def test_frame_shape_and_content(task):
    core, params = make(task)
    _, state = core.reset(jax.random.PRNGKey(0), params)
    scene = render.Scene(core, params)
    frame = scene.frame(state)
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert frame.shape[0] > 100 and frame.shape[1] > 100
    assert len(np.unique(frame.reshape(-1, 3), axis=0)) > 5  # not blank
    moved = np.asarray(state.x).copy()
    moved[:2] += 0.3
    other = scene.frame(moved)
    assert other.shape == frame.shape and not np.array_equal(frame, other)


def test_overlay_and_muscle_shading_change_pixels():
    core, params = make("ArmObstacle")
    _, state = core.reset(jax.random.PRNGKey(0), params)
    scene = render.Scene(core, params)
    plain = scene.frame(state)
    shaded = scene.frame(state, action=np.ones(6))
    marked = scene.frame(state, overlay=render.Overlay(
        goals=[(1.0, 2.2), (1.5, 1.0)], active_goal=1, trail=[(0.0, 0.3), (-0.1, 0.4)],
        switch_points=[(-0.1, 0.4)], text=["step 3"]))
    assert not np.array_equal(plain, shaded)
    assert not np.array_equal(plain, marked)


def test_gif_round_trip_and_speed(tmp_path):
    run = envs_cmd.demo_rollout("ArmObstacle")
    start = time.perf_counter()
    frames = render.render_rollout(run["core"], run["params"], run["states"], run["actions"],
                                   run["rewards"], goals=run["goals"])
    path = render.write_gif(frames, tmp_path / "arm.gif", fps=25)
    elapsed = time.perf_counter() - start
    assert len(frames) == 76
    assert elapsed < 5.0, f"drawing and writing 76 frames took {elapsed:.1f} s"
    with Image.open(path) as gif:
        assert gif.n_frames == 76 and gif.size == frames[0].shape[1::-1]


def test_cli_help_and_version(capsys):
    assert cli.main(["--help"]) == 0
    out = capsys.readouterr().out
    assert "envs" in out and "usage: hiddpg" in out
    assert cli.main(["--version"]) == 0
    assert capsys.readouterr().out.strip().startswith("hiddpg ")
    assert cli.main(["nope"]) == 2
    assert "nope" in capsys.readouterr().err


def test_envs_list(capsys):
    assert cli.main(["envs", "list"]) == 0
    out = capsys.readouterr().out
    for spec in TASKS.values():
        assert spec.env_id in out


def test_envs_demo_writes_gif(tmp_path, capsys):
    out = tmp_path / "tmp.gif"
    assert cli.main(["envs", "demo", "PuckTrajectory2", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    ret = float(re.search(r"return (-?[\d.]+)", printed).group(1))
    assert abs(ret) < 1e-3
    with Image.open(out) as gif:
        assert gif.n_frames >= 30


def test_envs_demo_set_changes_params(tmp_path, capsys):
    out = tmp_path / "short.gif"
    argv = ["envs", "demo", "hiddpg/ArmObstacle-v0", "--out", str(out), "--set", "max_steps=12",
            "--set", "field=cw"]
    assert cli.main(argv) == 0
    assert "over 12 steps" in capsys.readouterr().out
    with Image.open(out) as gif:
        assert gif.n_frames == 13


@pytest.mark.parametrize("argv, named", [
    (["envs", "demo", "NoSuchTask", "--out", "x.gif"], "NoSuchTask"),
    (["envs", "demo", "ArmReach", "--out", "x.gif", "--set", "bogus=1"], "bogus"),
    (["envs", "demo", "ArmReach", "--out", "x.gif", "--set", "field"], "KEY=VALUE"),
])
def test_envs_demo_errors(argv, named, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert named in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "x.gif").exists()


def test_script_exit_code_without_traceback(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-m", "hiddpg.cli", "envs", "demo", "Nope", "--out", "x.gif"],
        capture_output=True, text=True, cwd=tmp_path, timeout=120,
    )
    assert proc.returncode == 2
    assert "Nope" in proc.stderr and "Traceback" not in proc.stderr


def test_parse_overrides():
    parsed = envs_cmd.parse_overrides(["field=cw", "dt=0.05", "goals=[[1, 0]]", "max_steps=7"])
    assert parsed == {"field": "cw", "dt": 0.05, "goals": [[1, 0]], "max_steps": 7}
