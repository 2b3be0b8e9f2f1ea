"""Path arguments: :mod:`hiddpg.paths` and every command that writes a GIF, picture or figure
or reads runs. A bad path exits with code 2 before anything is computed, in one line naming the
value and what is allowed; a good one is written, missing directories created."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from hiddpg import paths
from hiddpg.commands import envs as envs_cmd
from hiddpg.commands import eval as eval_cmd
from hiddpg.commands import ilqr as ilqr_cmd
from hiddpg.commands import plot as plot_cmd
from hiddpg.commands.common import UsageError


def one_line_error(capsys, *named: str) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    for text in named:
        assert text in err, err
    return err


# --------------------------------------------------------------------------- the helpers


def test_gif_path_accepts_gif_names_and_keeps_missing_directories_for_later(tmp_path):
    target = tmp_path / "new" / "deeper" / "a.GIF"
    assert paths.gif_path(str(target), "--gif") == target
    assert not (tmp_path / "new").exists()  # created when the file is written, not by the check


@pytest.mark.parametrize("name, says", [
    ("afile", "must end in .gif"), ("a.png", "must end in .gif"), ("", "is empty"),
])
def test_gif_path_rejects_other_names(tmp_path, name, says):
    with pytest.raises(paths.PathError, match=says) as info:
        paths.gif_path(str(tmp_path / name) if name else name, "--gif")
    assert isinstance(info.value, UsageError) and "--gif" in str(info.value)


def test_gif_path_suggests_the_name_with_gif(tmp_path):
    with pytest.raises(paths.PathError, match=r"e\.g\. --gif .*afile\.gif"):
        paths.gif_path(str(tmp_path / "afile"), "--gif")


def test_output_file_rejects_a_directory_and_a_file_as_parent(tmp_path):
    (tmp_path / "d.gif").mkdir()
    with pytest.raises(paths.PathError, match="is a directory"):
        paths.gif_path(str(tmp_path / "d.gif"))
    (tmp_path / "plain").write_text("x")
    with pytest.raises(paths.PathError, match="is a file, not a directory"):
        paths.gif_path(str(tmp_path / "plain" / "sub" / "a.gif"))
    with pytest.raises(paths.PathError, match="is a directory"):
        paths.output_file(str(tmp_path), "--json")


def test_figure_stem(tmp_path):
    assert paths.figure_stem(str(tmp_path / "cmp")) == tmp_path / "cmp"
    assert paths.figure_stem(str(tmp_path / "cmp.pdf")) == tmp_path / "cmp"
    assert paths.figure_stem(str(tmp_path / "cmp.v2")) == tmp_path / "cmp.v2"
    (tmp_path / "out").mkdir()
    with pytest.raises(paths.PathError, match="'.*out' .*is a directory"):
        paths.figure_stem(str(tmp_path / "out"))
    (tmp_path / "fig.png").mkdir()
    with pytest.raises(paths.PathError, match="fig.png is a directory"):
        paths.figure_stem(str(tmp_path / "fig"))


def test_output_dir(tmp_path):
    assert paths.output_dir(str(tmp_path / "new"), "--out") == tmp_path / "new"
    assert paths.output_dir(str(tmp_path), "--out") == tmp_path
    (tmp_path / "f").write_text("x")
    with pytest.raises(paths.PathError, match="--out '.*f' is a file; give a directory"):
        paths.output_dir(str(tmp_path / "f"), "--out")


def test_existing_dir_suggests_timestamped_siblings(tmp_path):
    runs = tmp_path / "runs"
    (runs / "ddpg-PuckObstacle-20261124-101500").mkdir(parents=True)
    (runs / "hi-ddpg-PuckObstacle-20261124-101500").mkdir()
    assert paths.existing_dir(str(runs), "RUN_DIR") == runs
    with pytest.raises(paths.PathError) as info:
        paths.existing_dir(str(runs / "ddpg-PuckObstacle"), "RUN_DIR")
    message = str(info.value)
    assert "RUN_DIR" in message and "ddpg-PuckObstacle' does not exist" in message
    assert message.endswith(f"did you mean {runs / 'ddpg-PuckObstacle-20261124-101500'}?")
    for stamp in ("20261125-090000", "20261126-090000", "20261127-090000"):
        (runs / f"ddpg-PuckObstacle-{stamp}").mkdir()
    with pytest.raises(paths.PathError, match="newest 3 of 4") as info:
        paths.existing_dir(str(runs / "ddpg-PuckObstacle"), "RUN_DIR")
    assert "20261127-090000" in str(info.value) and "20261124" not in str(info.value)
    with pytest.raises(paths.PathError, match="does not exist$"):
        paths.existing_dir(str(runs / "nothing-like-it"), "RUN_DIR")


# -------------------------------------------------------------------------- the commands


@pytest.mark.parametrize("gif, named", [
    ("afile", ["'afile'", "must end in .gif"]),
    ("sub", ["'sub'", "is a directory"]),
    ("", ["--gif is empty"]),
])
def test_eval_gif_checked_before_the_run_is_opened(tmp_path, monkeypatch, capsys, gif, named):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub.gif").mkdir()
    gif = "sub.gif" if gif == "sub" else gif
    named = [n.replace("'sub'", "'sub.gif'") for n in named]
    assert eval_cmd.main(["no-such-run", "--gif", gif]) == 2  # the run is never looked at
    one_line_error(capsys, "hiddpg eval", *named)


def test_eval_missing_run_suggests_the_timestamped_one(tmp_path, capsys):
    (tmp_path / "hi-ddpg-PuckTrajectory1-20261124-101500").mkdir()
    assert eval_cmd.main([str(tmp_path / "hi-ddpg-PuckTrajectory1")]) == 2
    one_line_error(capsys, "does not exist", "did you mean",
                   str(tmp_path / "hi-ddpg-PuckTrajectory1-20261124-101500"))


@pytest.mark.parametrize("extra, named", [
    (["--out", "afile"], ["--out 'afile'", "must end in .gif"]),
    (["--out", "d.gif"], ["--out 'd.gif'", "is a directory"]),
    (["--out", "x.gif", "--still", "x.jpg"], ["--still 'x.jpg'", "must end in .png"]),
    (["--out", "x.gif", "--width", "10"], ["--width 10", "at least"]),
])
def test_envs_demo_paths_checked_before_the_rollout(tmp_path, monkeypatch, capsys, extra, named):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "d.gif").mkdir()
    monkeypatch.setattr(envs_cmd, "demo_rollout", lambda *a, **k: pytest.fail("rolled out"))
    assert envs_cmd.main(["demo", "PuckTrajectory1", *extra]) == 2
    one_line_error(capsys, *named)
    assert not (tmp_path / "x.gif").exists()


def test_envs_demo_creates_missing_directories(tmp_path, capsys):
    out, still = tmp_path / "a" / "b" / "demo.gif", tmp_path / "c" / "last.png"
    argv = ["demo", "PuckTrajectory1", "--out", str(out), "--still", str(still),
            "--set", "max_steps=5"]
    assert envs_cmd.main(argv) == 0
    with Image.open(out) as gif:
        assert gif.n_frames == 6
    with Image.open(still) as png:
        assert png.size == gif.size
    assert envs_cmd.main([*argv, "--still-step", "9"]) == 2
    one_line_error(capsys, "--still-step 9", "[-6, 5]")


@pytest.mark.parametrize("extra, named", [
    (["--gif", "sol"], ["--gif 'sol'", "must end in .gif"]),
    (["--json", "d.gif"], ["--json 'd.gif'", "is a directory"]),
    (["--gif", "f/x.gif"], ["--gif 'f/x.gif'", "is a file, not a directory"]),
])
def test_ilqr_paths_checked_before_solving(tmp_path, monkeypatch, capsys, extra, named):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "d.gif").mkdir()
    (tmp_path / "f").write_text("x")
    monkeypatch.setattr(ilqr_cmd, "resolve", lambda *a, **k: pytest.fail("resolved"))
    assert ilqr_cmd.main(["PuckTrajectory1", *extra]) == 2
    one_line_error(capsys, "hiddpg ilqr", *named)


def test_plot_out_and_run_dirs_checked_before_reading(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "runs" / "ddpg-PuckObstacle-20261124-101500").mkdir(parents=True)
    assert plot_cmd.main(["runs", "--out", "runs"]) == 2
    one_line_error(capsys, "hiddpg plot", "--out 'runs'", "is a directory")
    assert plot_cmd.main(["runs/ddpg-PuckObstacle"]) == 2
    one_line_error(capsys, "RUN_DIR 'runs/ddpg-PuckObstacle' does not exist",
                   "did you mean runs/ddpg-PuckObstacle-20261124-101500?")
    assert not (tmp_path / "comparison.png").exists()


def test_plot_out_with_an_extension_writes_the_pair_in_new_directories(tmp_path, capsys):
    from hiddpg.presets import make_config
    from hiddpg.runs import Run

    run = Run.create(tmp_path / "runs" / "ddpg-PuckObstacle-20261124-101500",
                     make_config("ddpg", "PuckObstacle", "quick", ["episodes=4", "eval_every=2"]),
                     (0, 1))
    ep = np.tile(np.arange(1, 5), (2, 1))
    score = np.arange(4.0)[None] + np.array([[0.0], [1.0]])
    run.append_metrics({"episode": ep, "length": np.full(ep.shape, 50), "return": score,
                        "env_return": score, "switches": np.zeros(ep.shape)},
                       {"episode": ep[:, 1::2], "return": score[:, 1::2],
                        "env_return": score[:, 1::2]})
    out = tmp_path / "new" / "deeper" / "cmp.png"
    assert plot_cmd.main([str(tmp_path / "runs"), "--out", str(out), "--stages", "2"]) == 0
    assert (out.parent / "cmp.png").is_file() and (out.parent / "cmp.pdf").is_file()
    assert f"wrote {out.parent / 'cmp.png'}, {out.parent / 'cmp.pdf'}" in capsys.readouterr().out
