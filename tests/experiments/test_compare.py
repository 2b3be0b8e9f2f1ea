"""Pooled per-seed comparisons across exported study records (hiddpg.experiments.compare)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hiddpg.experiments import compare
from hiddpg.experiments.diagnosis import welch_interval


def _record(path, runs: dict[str, tuple[list, list, list]]):
    """A record whose runs have, per seed, evaluation curves of 6 points: the return, the
    critic's first value and the discounted return it got."""
    out = {"at": 10, "window": 5, "last_evals": 5, "runs": []}
    for label, (ret, q, disc) in runs.items():
        out["runs"].append({"run": label, "eval": {
            "eval_env_return": [[-999.0] + [r] * 5 for r in ret],
            "eval_high_q_start": [[0.0] + [v] * 5 for v in q],
            "eval_high_return_discounted": [[0.0] + [v] * 5 for v in disc]}})
    path.write_text(json.dumps(out))
    return str(path)


def test_runs_are_pooled_by_seed_and_compared_by_welch(tmp_path, capsys):
    r1 = _record(tmp_path / "one.json", {"x": ([-10, -12], [-50, -40], [-12, -11]),
                                          "y": ([-14, -13], [-20, -18], [-14, -12])})
    r2 = _record(tmp_path / "two.json", {"x": ([-11, -9, -13], [-60, -45, -48], [-11, -9, -13])})
    # the first evaluation is not among the last five: -999 never enters
    np.testing.assert_allclose(compare.seed_values(r1, "x"), [-10, -12])
    np.testing.assert_allclose(compare.seed_values(r1, "x", "critic_error"), [-38, -29])
    np.testing.assert_allclose(compare.seed_values(r1, "y", "abs_critic_error"), [6, 6])
    out = compare.compare([(r1, "x"), (r2, "x")], [(r1, "y")])
    np.testing.assert_allclose(out["a"], [-10, -12, -11, -9, -13])
    want = welch_interval(np.array([-10, -12, -11, -9, -13.0]), np.array([-14, -13.0]))
    assert (out["diff"], out["low"], out["high"]) == pytest.approx(want)
    assert out["diff"] == pytest.approx(-11.0 + 13.5)
    assert compare.main(["--a", r1, "x", "--a", r2, "x", "--b", r1, "y",
                         "--metric", "abs_critic_error"]) == 0
    text = capsys.readouterr().out
    assert "a: abs_critic_error per seed +38.00, +29.00, +49.00, +36.00, +35.00" in text
    assert "a - b: +31.40 [" in text


def test_bad_input_is_one_line_naming_it(tmp_path, capsys):
    r1 = _record(tmp_path / "one.json", {"x": ([-10, -12], [0, 0], [0, 0])})
    assert compare.main(["--a", r1, "nope", "--b", r1, "x"]) == 2
    assert compare.main(["--a", str(tmp_path / "missing.json"), "x", "--b", r1, "x"]) == 2
    assert compare.main(["--a", r1, "x"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 3
    assert "no run labelled 'nope'; its runs are ['x']" in err[0]
    assert "missing.json: no such record" in err[1]
    assert "at least one run on each side" in err[2]
    with pytest.raises(ValueError, match="metric 'q': choose one of"):
        compare.seed_values(r1, "x", "q")
