"""Tests for hiddpg.experiments.stats: agreement with SciPy, known cases, bootstrap coverage."""

import warnings

import numpy as np
import pytest
from scipy import stats as sps

from hiddpg.experiments.stats import (
    ConfidenceInterval,
    holm,
    iqm,
    pairwise_welch,
    probability_of_improvement,
    signed_log_p,
    stratified_bootstrap_ci,
    summarize,
    welch_t,
)


@pytest.fixture
def rng():
    return np.random.default_rng(1234)


# ------------------------------------------------------------------------------ Welch t


@pytest.mark.parametrize("n_a, n_b", [(2, 2), (5, 9), (15, 15), (30, 4)])
def test_welch_t_matches_scipy(rng, n_a, n_b):
    for _ in range(20):
        a = rng.normal(rng.normal(), rng.uniform(0.1, 3.0), n_a)
        b = rng.normal(rng.normal(), rng.uniform(0.1, 3.0), n_b)
        t, p = welch_t(a, b)
        ref = sps.ttest_ind(a, b, equal_var=False)
        assert isinstance(t, float) and isinstance(p, float)
        np.testing.assert_allclose([t, p], [ref.statistic, ref.pvalue], rtol=1e-10)


def test_welch_t_vectorises_over_stages(rng):
    a, b = rng.normal(size=(15, 7)), rng.normal(0.5, 2.0, size=(10, 7))
    t, p = welch_t(a, b)
    ref = sps.ttest_ind(a, b, equal_var=False, axis=0)
    assert t.shape == p.shape == (7,)
    np.testing.assert_allclose(t, ref.statistic, rtol=1e-10)
    np.testing.assert_allclose(p, ref.pvalue, rtol=1e-10)


def test_welch_t_zero_variance():
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no RuntimeWarning from 0/0 or 0*inf
        assert welch_t([0.1] * 3, [0.1] * 4) == (0.0, 1.0)
        assert welch_t([1.0, 1.0], [2.0, 2.0, 2.0]) == (-np.inf, 0.0)
        assert welch_t([3.0, 3.0], [2.0, 2.0]) == (np.inf, 0.0)
    # one constant group: the ordinary formula with df = n_other - 1 (as SciPy)
    a, b = [1.0, 1.0, 1.0], [2.0, 3.0, 2.0, 4.0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # SciPy warns on the constant group
        ref = sps.ttest_ind(a, b, equal_var=False)
    np.testing.assert_allclose(welch_t(a, b), (ref.statistic, ref.pvalue), rtol=1e-10)
    t, p = welch_t(np.ones((3, 2)), np.array([[1.0, 1.0], [1.0, 2.0], [1.0, 3.0]]))
    assert t[0] == 0.0 and p[0] == 1.0 and t[1] < 0 and 0 < p[1] < 1


@pytest.mark.parametrize(
    "a, b, match",
    [
        ([1.0], [1.0, 2.0], "a needs at least 2 runs"),
        ([1.0, 2.0], [3.0], "b needs at least 2 runs"),
        ([], [1.0, 2.0], "a must be a non-empty"),
        ([1.0, np.nan], [1.0, 2.0], "a contains NaN"),
        ([1.0, 2.0], [1.0, np.inf], "b contains NaN or inf"),
    ],
)
def test_welch_t_bad_input(a, b, match):
    with pytest.raises(ValueError, match=match):
        welch_t(a, b)


def test_signed_log_p():
    assert signed_log_p(2.0, 0.01) == pytest.approx(2.0)
    assert signed_log_p(-2.0, 0.01) == pytest.approx(-2.0)
    assert signed_log_p(0.0, 1.0) == 0.0
    assert signed_log_p(-np.inf, 0.0) == -np.inf
    np.testing.assert_allclose(signed_log_p([1.0, -1.0, 3.0], [0.1, 0.1, 1e-3]), [1.0, -1.0, 3.0])
    with pytest.raises(ValueError, match="p must hold p-values"):
        signed_log_p(1.0, 1.5)


# ---------------------------------------------------------------------------------- Holm


def test_holm_hand_computed():
    # sorted: 0.005*4 = 0.02, 0.01*3 = 0.03, 0.03*2 = 0.06, 0.04*1 = 0.04 -> cummax 0.06
    p = np.array([0.01, 0.04, 0.03, 0.005])
    np.testing.assert_allclose(holm(p), [0.03, 0.06, 0.06, 0.02])
    # capped at 1, ties share a value, any shape is one family
    np.testing.assert_allclose(holm([0.6, 0.02, 0.02]), [0.6, 0.06, 0.06])
    np.testing.assert_allclose(holm([[0.5, 0.9], [0.3, 0.01]]), [[1.0, 1.0], [0.9, 0.04]])


def test_holm_properties(rng):
    p = rng.uniform(size=(6, 5)) ** 3
    adj = holm(p)
    assert adj.shape == p.shape
    assert np.all(adj >= p) and np.all(adj <= 1.0)
    order = np.argsort(p.ravel())
    assert np.all(np.diff(adj.ravel()[order]) >= 0)  # monotone in the raw p-values
    assert adj.min() == pytest.approx(min(1.0, p.size * p.min()))


@pytest.mark.parametrize("bad", [[], [0.1, np.nan], [0.1, 1.2], [-0.1]])
def test_holm_bad_input(bad):
    with pytest.raises(ValueError, match="pvalues"):
        holm(bad)


# ------------------------------------------------------------------------ pairwise table


def test_pairwise_welch_table(rng):
    results = {
        "HI-DDPG": rng.normal(2.0, 1.0, (15, 4)),
        "h-DDPG": rng.normal(0.0, 1.0, (12, 4)),
        "DDPG": rng.normal(0.0, 1.0, (15, 4)),
    }
    table = pairwise_welch(results)
    assert table.methods == ("HI-DDPG", "h-DDPG", "DDPG")
    assert table.t.shape == table.p.shape == table.p_holm.shape == (3, 3, 4)
    t, p = welch_t(results["HI-DDPG"], results["DDPG"])
    np.testing.assert_allclose(table.t[0, 2], t)
    np.testing.assert_allclose(table.t[2, 0], -t)
    np.testing.assert_allclose(table.p[2, 0], p)
    assert np.all(np.isnan(table.t[[0, 1, 2], [0, 1, 2]]))
    upper = np.triu_indices(3, k=1)
    np.testing.assert_allclose(table.p_holm[upper], holm(table.p[upper]))  # 3 pairs x 4 stages
    per_stage = pairwise_welch(results, holm_family="stage")
    np.testing.assert_allclose(per_stage.p_holm[upper][:, 1], holm(table.p[upper][:, 1]))
    tile = table.tile("HI-DDPG", "DDPG")
    np.testing.assert_allclose(tile, -np.log10(p) * np.sign(t))
    assert np.all(tile > 0)  # HI-DDPG is clearly better at every stage
    rows = list(table.records())
    assert len(rows) == 6 * 4
    assert set(rows[0]) == {"method_a", "method_b", "stage", "t", "p", "p_holm"}


def test_pairwise_welch_bad_input(rng):
    with pytest.raises(ValueError, match="at least two method"):
        pairwise_welch({"a": rng.normal(size=(3, 2))})
    with pytest.raises(ValueError, match="same number of stages"):
        pairwise_welch({"a": rng.normal(size=(3, 2)), "b": rng.normal(size=(3, 3))})
    with pytest.raises(ValueError, match=r"results\['b'\] needs at least 2 runs"):
        pairwise_welch({"a": rng.normal(size=(3, 2)), "b": rng.normal(size=(1, 2))})
    table = pairwise_welch({"a": rng.normal(size=(3, 2)), "b": rng.normal(size=(3, 2))})
    with pytest.raises(ValueError, match="method_b='c'"):
        table.tile("a", "c")


# ------------------------------------------------------------------ robust aggregates


@pytest.mark.parametrize("shape", [(4,), (15,), (17, 3), (10, 6)])
def test_iqm_matches_trim_mean(rng, shape):
    x = rng.standard_cauchy(shape)
    assert iqm(x) == pytest.approx(sps.trim_mean(x.ravel(), 0.25), rel=1e-12)


def test_probability_of_improvement_matches_mann_whitney(rng):
    for n, m in [(5, 7), (15, 15), (3, 20)]:
        x = rng.integers(0, 6, n).astype(float)  # integers: plenty of ties
        y = rng.integers(0, 6, m).astype(float)
        u = sps.mannwhitneyu(x, y, alternative="two-sided").statistic
        assert probability_of_improvement(x, y) == pytest.approx(u / (n * m))


def test_probability_of_improvement_known_cases(rng):
    x = rng.normal(size=10)
    assert probability_of_improvement(x + 100.0, x) == 1.0
    assert probability_of_improvement(x, x + 100.0) == 0.0
    assert probability_of_improvement(np.ones(5), np.ones(8)) == 0.5
    # (runs, tasks): mean over tasks of the per-task probability
    xs, ys = rng.normal(size=(6, 3)), rng.normal(size=(9, 3))
    per_task = [probability_of_improvement(xs[:, k], ys[:, k]) for k in range(3)]
    assert probability_of_improvement(xs, ys) == pytest.approx(np.mean(per_task))
    with pytest.raises(ValueError, match="same number of tasks"):
        probability_of_improvement(xs, ys[:, :2])


def test_bootstrap_ci_coverage_of_the_mean():
    true_mean, n_runs, reps = 3.0, 30, 200
    rng = np.random.default_rng(0)
    covered = 0
    for rep in range(reps):
        sample = rng.normal(true_mean, 2.0, n_runs)
        ci = stratified_bootstrap_ci(sample, np.mean, n_boot=400, seed=rep)
        assert ci.low <= ci.estimate <= ci.high
        covered += ci.low <= true_mean <= ci.high
    # nominal 95%; binomial sd over 200 reps is 1.5%, percentile bootstrap under-covers a bit
    assert 0.89 <= covered / reps <= 0.99


def test_bootstrap_is_stratified_and_deterministic(rng):
    scores = {"a": rng.normal(size=(8, 3)), "b": rng.normal(size=(5, 3))}
    first = stratified_bootstrap_ci(scores, iqm, n_boot=300, seed=7)
    again = stratified_bootstrap_ci(dict(reversed(list(scores.items()))), iqm, n_boot=300, seed=7)
    assert set(first) == {"a", "b"} and isinstance(first["a"], ConfidenceInterval)
    assert first == again  # same seed, any dict order
    assert stratified_bootstrap_ci(scores["a"], iqm, n_boot=300, seed=8) != first["a"]
    # stratified: each task keeps its own runs, so per-task column means stay in their range
    tasks = np.array([[0.0, 100.0]] * 3 + [[1.0, 101.0]] * 3)
    ci = stratified_bootstrap_ci(tasks, lambda s: s[:, 1].min() - s[:, 0].max(), n_boot=200)
    assert ci.low >= 99.0


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"ci": 1.0}, "ci must lie"),
        ({"ci": 0.0}, "ci must lie"),
        ({"n_boot": 0}, "n_boot"),
        ({"statistic": 3}, "statistic must be callable"),
    ],
)
def test_bootstrap_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        stratified_bootstrap_ci(np.arange(5.0), **kwargs)


def test_bootstrap_bad_scores():
    with pytest.raises(ValueError, match=r"scores\['x'\] contains NaN"):
        stratified_bootstrap_ci({"x": [1.0, np.nan]})
    with pytest.raises(ValueError, match="scores must be 1-D"):
        stratified_bootstrap_ci(np.ones((2, 2, 2)))
    with pytest.raises(ValueError, match="empty mapping"):
        stratified_bootstrap_ci({})


def test_summarize(rng):
    x = rng.normal(5.0, 1.0, 15)
    s = summarize(x, n_boot=500)
    assert set(s) == {"mean", "std", "iqm", "ci_low", "ci_high", "n"}
    assert s["n"] == 15
    assert s["mean"] == pytest.approx(x.mean())
    assert s["std"] == pytest.approx(x.std(ddof=1))
    assert s["iqm"] == pytest.approx(sps.trim_mean(x, 0.25))
    assert s["ci_low"] <= s["iqm"] <= s["ci_high"]
    assert np.isnan(summarize([2.0])["std"])
    with pytest.raises(ValueError, match="x must be a non-empty"):
        summarize([])
