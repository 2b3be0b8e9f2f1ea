"""The golden runs (``scripts/golden.py``): short runs of the algorithms, presets and HI-DDPG's
parts give the metrics recorded in ``tests/golden/metrics.json``. ``scripts/golden.py check``
compares all of them bit for bit on one machine; this test runs a few of them with a tolerance
for another CPU's rounding."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
#: in CI: the arm's HI-DDPG (the most parts: both levels' DDPG blocks, the model, the
#: pre-training); h-DDPG's and the puck's HI-DDPG cases are heavy
CASES = ("hi-ddpg/ArmObstacle/quick+arm-high-critic",
         *(pytest.param(c, marks=pytest.mark.heavy) for c in (
             "h-ddpg/PuckObstacle/quick", "hi-ddpg/PuckTrajectory1/quick",
             "hi-ddpg/PuckTrajectory2/quick+critic-durations")))


def _golden_module():
    spec = importlib.util.spec_from_file_location("golden", ROOT / "scripts" / "golden.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
@pytest.mark.xla_optimized  # the metrics were recorded from XLA's default build
@pytest.mark.parametrize("name", CASES)
def test_a_golden_run_gives_the_recorded_metrics(name):
    golden = _golden_module()
    recorded = json.loads((ROOT / "tests" / "golden" / "metrics.json").read_text())[name]
    got = golden.run(*golden.cases()[name])
    for part in ("train", "eval"):
        assert set(got["values"][part]) == set(recorded["values"][part])
        for key, values in recorded["values"][part].items():
            np.testing.assert_allclose(got["values"][part][key], values, rtol=1e-3, atol=1e-4,
                                       err_msg=f"{name} {part} {key}")


def _case(train: dict, digest: str = "s") -> dict:
    return {"sha256": digest, "state_sha256": digest, "values": {"train": train, "eval": {}}}


def test_merge_adds_only_missing_keys_and_keeps_recorded_values(tmp_path, capsys):
    golden = _golden_module()
    path = tmp_path / "metrics.json"
    recorded = {"a": _case({"loss": [1.0]}, "old"), "b": _case({"loss": [2.0], "gone": [0.0]})}
    new = {"a": _case({"loss": [1.5], "q": [3.0]}, "new"), "b": _case({"loss": [2.0]}),
           "c": _case({"loss": [4.0]})}
    assert golden._merge(str(path), recorded, new) == 1  # c is unrecorded, b/gone not logged
    merged = json.loads(path.read_text())
    assert merged["a"] == _case({"loss": [1.0], "q": [3.0]}, "old")
    assert merged["b"] == _case({"loss": [2.0], "gone": [0.0]}) and "c" not in merged
    out = capsys.readouterr().out
    assert "a: added train/q" in out and "record it): c" in out and "b: train/gone" in out
    assert golden._merge(str(path), merged, {"a": new["a"]}) == 0
    assert list(tmp_path.iterdir()) == [path]  # no temporary file left
