"""benchmarks/_demo_summary.py: the Gymnasium demo's records merged over parts of seeds (ours)
and single seeds (SB3) into one curve per method, and its table."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from _demo_summary import curves, summarize  # noqa: E402


def _ours(out, method, seeds, evals, finished=True):
    path = out / "records" / method / ("seeds-" + "-".join(map(str, seeds)) + ".json")
    path.parent.mkdir(parents=True, exist_ok=True)
    rec = {"seeds": seeds, "finished": finished,
           "evals": [{"steps": s, "returns": r} for s, r in evals]}  # r: (seed, episode)
    path.write_text(json.dumps(rec))


def _sb3(out, method, seed, evals):
    path = out / "records" / method / f"seed{seed}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"seed": seed, "evals": [{"steps": s, "returns": r}
                                                        for s, r in evals]}))


def test_parts_merge_in_seed_order_and_unfinished_parts_are_left_out(tmp_path, capsys):
    _ours(tmp_path, "hi-ddpg", [3, 4], [(0, [[-9, -7], [-5, -5]]), (50, [[-2, -4], [-1, -1]])])
    _ours(tmp_path, "hi-ddpg", [0, 1, 2], [(0, [[-8], [-6], [-4]]), (50, [[-3], [-2], [-1]])])
    _ours(tmp_path, "hi-ddpg", [5], [(0, [[-99]])], finished=False)
    for seed, last in [(1, -6.0), (0, -2.0)]:
        _sb3(tmp_path, "sb3-td3", seed, [(0, [-10.0, -12.0]), (50, [last, last + 2])])
    found = curves(tmp_path, ["hi-ddpg", "ddpg", "sb3-td3"])
    assert set(found) == {"hi-ddpg", "sb3-td3"}
    steps, values, seeds = found["hi-ddpg"]
    assert seeds == [0, 1, 2, 3, 4] and steps.tolist() == [0, 50]
    np.testing.assert_allclose(values, [[-8, -3], [-6, -2], [-4, -1], [-8, -3], [-5, -1]])
    steps, values, seeds = found["sb3-td3"]
    assert seeds == [0, 1]
    np.testing.assert_allclose(values, [[-11, -1], [-11, -5]])
    assert "seeds-5.json: not finished, left out" in capsys.readouterr().out

    summarize(tmp_path, ["hi-ddpg", "sb3-td3"], "demo")
    table = (tmp_path / "table.md").read_text().splitlines()
    assert table[2].startswith("| hi-ddpg | 0-4 | 50 | -2 ± 1 |")
    assert table[3].startswith("| sb3-td3 | 0-1 | 50 | -3 ± 2.8 |")
    assert (tmp_path / "curves.png").is_file()


def test_parts_evaluated_at_other_steps_are_refused(tmp_path):
    _ours(tmp_path, "ddpg", [0], [(0, [[-1]]), (50, [[-1]])])
    _ours(tmp_path, "ddpg", [1], [(0, [[-1]]), (40, [[-1]])])
    with pytest.raises(SystemExit, match="evaluated at other steps"):
        curves(tmp_path, ["ddpg"])


def test_the_demo_names_the_missing_extra_instead_of_a_traceback(tmp_path):
    """SB3 methods asked for without stable-baselines3: a usage error naming the extra, before
    anything is trained or probed (stable-baselines3 hidden from the child process)."""
    root = Path(__file__).resolve().parents[1]
    hide = tmp_path / "hide"
    hide.mkdir()
    (hide / "sitecustomize.py").write_text("import sys\nsys.modules['stable_baselines3'] = None\n")
    env = {**os.environ, "PYTHONPATH": str(hide)}
    proc = subprocess.run(
        [sys.executable, str(root / "benchmarks" / "gym_demo.py"), "--env", "Reacher-v5",
         "--estimate-only", "--methods", "sb3-td3", "--out", str(tmp_path / "out")],
        capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 2, proc.stderr[-2000:]
    assert "Traceback" not in proc.stderr
    assert "sb3-td3" in proc.stderr and '.[bench]' in proc.stderr
    assert not (tmp_path / "out").exists()
