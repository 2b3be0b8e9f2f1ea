"""Statistics for comparing RL methods, with the run (seed) as the unit of replication.

Two families, both NumPy/SciPy only (algorithms.md §6):

* The paper's Fig. 7/8 tiles: Welch's two-sided t-test between two methods at each training
  stage, coloured by ``-log10(p) * sign(t)`` (:func:`welch_t`, :func:`signed_log_p`,
  :func:`pairwise_welch`), with Holm–Bonferroni adjustment for the many tests (:func:`holm`).
* Robust aggregates after Agarwal et al. (2021, "Deep RL at the edge of the statistical
  precipice", the ``rliable`` library): the interquartile mean (:func:`iqm`), stratified
  percentile-bootstrap confidence intervals (:func:`stratified_bootstrap_ci`) and the
  probability of improvement (:func:`probability_of_improvement`).

Every function takes runs on axis 0. Bad input (empty, NaN/inf, too few runs, ``ci`` outside
(0, 1)) raises ``ValueError`` naming the offending argument.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np
from scipy import stats as sps

IQM_TRIM = 0.25
"""Fraction cut from each end for the interquartile mean."""
MIN_RUNS_T_TEST = 2
"""A t-test needs a sample variance, hence at least two runs per group."""
TIE_WEIGHT = 0.5
"""Weight of ties (X = Y) in the probability of improvement."""

Array = np.ndarray


class ConfidenceInterval(NamedTuple):
    """A point estimate with its percentile-bootstrap interval ``[low, high]``."""

    estimate: float
    low: float
    high: float


# ----------------------------------------------------------------------------- validation


def _runs(x, name: str, min_runs: int = 1) -> Array:
    """``x`` as a finite float array with at least ``min_runs`` runs on axis 0."""
    arr = np.asarray(x, dtype=np.float64)
    if arr.ndim == 0 or arr.size == 0:
        raise ValueError(
            f"{name} must be a non-empty array with runs on axis 0, got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or inf; drop or impute failed runs first")
    if arr.shape[0] < min_runs:
        raise ValueError(f"{name} needs at least {min_runs} runs on axis 0, got {arr.shape[0]}")
    return arr


def _run_by_task(x, name: str, min_runs: int = 1) -> Array:
    """``x`` as a (runs, tasks) array; a 1-D array is one task."""
    arr = _runs(x, name, min_runs)
    if arr.ndim == 1:
        return arr[:, None]
    if arr.ndim != 2:
        raise ValueError(f"{name} must be 1-D (runs,) or 2-D (runs, tasks), got shape {arr.shape}")
    return arr


def _pvalues(p, name: str) -> Array:
    arr = np.asarray(p, dtype=np.float64)
    if arr.size == 0:
        raise ValueError(f"{name} must be non-empty")
    if np.any(np.isnan(arr)) or np.any((arr < 0) | (arr > 1)):
        raise ValueError(f"{name} must hold p-values in [0, 1] (no NaN)")
    return arr


# ------------------------------------------------------------------------ Welch t and Holm


def welch_t(a, b) -> tuple[float | Array, float | Array]:
    """Welch's unequal-variance two-sided t-test of ``mean(a) != mean(b)`` over runs.

    ``a`` (n_a, ...) and ``b`` (n_b, ...) hold runs on axis 0; any trailing axes (e.g. training
    stages) are tested elementwise and must broadcast. Matches
    ``scipy.stats.ttest_ind(a, b, equal_var=False)``, with degrees of freedom by
    Welch–Satterthwaite. ``t > 0`` means ``a`` has the higher mean.

    Zero variance is handled exactly (a group is constant when ``max == min``): if both groups
    are constant and equal, ``t = 0, p = 1`` (no evidence of a difference; SciPy gives NaN); if
    both are constant and differ, ``t = ±inf, p = 0`` (as SciPy); one constant group is the
    usual limit, with ``df = n_other - 1``.

    Returns ``(t, p)``: floats when there are no trailing axes, else arrays of that shape.
    """
    a = _runs(a, "a", MIN_RUNS_T_TEST)
    b = _runs(b, "b", MIN_RUNS_T_TEST)
    n_a, n_b = a.shape[0], b.shape[0]
    const_a, const_b = np.ptp(a, axis=0) == 0, np.ptp(b, axis=0) == 0
    # exact moments for constant groups, so floating-point dust cannot create a difference
    mean_a = np.where(const_a, a[0], a.mean(axis=0))
    mean_b = np.where(const_b, b[0], b.mean(axis=0))
    se2_a = np.where(const_a, 0.0, a.var(axis=0, ddof=1)) / n_a
    se2_b = np.where(const_b, 0.0, b.var(axis=0, ddof=1)) / n_b
    se2 = se2_a + se2_b
    both_const = se2 == 0
    safe = np.where(both_const, 1.0, se2)
    diff = mean_a - mean_b
    t = np.where(both_const, np.copysign(np.inf, diff), diff / np.sqrt(safe))
    t = np.where(both_const & (diff == 0), 0.0, t)
    df = safe**2 / (se2_a**2 / (n_a - 1) + se2_b**2 / (n_b - 1) + both_const)
    p = np.where(both_const, np.where(diff == 0, 1.0, 0.0), 2.0 * sps.t.sf(np.abs(t), df))
    if t.ndim == 0:
        return float(t), float(p)
    return t, p


def signed_log_p(t, p) -> float | Array:
    """The paper's tile colour ``-log10(p) * sign(t)`` (Figs. 7/8), elementwise.

    Base 10 is chosen so the value reads as "number of decimal places of significance":
    ``±1.3`` is ``p = 0.05``, ``±2`` is ``p = 0.01``. Positive means the first method is better.
    ``p = 0`` gives ``±inf`` (clip the colour scale when plotting); ``t = 0`` gives 0.
    """
    p = _pvalues(p, "p")
    t = np.asarray(t, dtype=np.float64)
    if np.any(np.isnan(t)):
        raise ValueError("t contains NaN")
    with np.errstate(divide="ignore", invalid="ignore"):  # p = 0 gives inf; 0 * inf fixed below
        out = -np.log10(p) * np.sign(t)
    out = np.where(np.sign(t) == 0, 0.0, out)
    return float(out) if out.ndim == 0 else out


def holm(pvalues) -> Array:
    """Holm–Bonferroni step-down adjusted p-values over all entries of ``pvalues``.

    With the ``m`` p-values sorted ascending ``p_(1) <= ... <= p_(m)``, the adjusted value is
    ``max_{j <= i} min(1, (m - j + 1) p_(j))`` — monotone in the raw p-values and capped at 1
    (as ``statsmodels.multipletests(method="holm")``). Reject at level α where adjusted ≤ α;
    this controls the family-wise error rate. Returns an array of the input's shape.
    """
    p = _pvalues(pvalues, "pvalues")
    flat = p.ravel()
    m = flat.size
    order = np.argsort(flat, kind="stable")
    scaled = np.minimum(1.0, (m - np.arange(m)) * flat[order])
    adjusted = np.empty(m)
    adjusted[order] = np.maximum.accumulate(scaled)
    return adjusted.reshape(p.shape)


@dataclass(frozen=True)
class PairwiseWelch:
    """Welch t-tests between every ordered pair of methods at every stage (Figs. 7/8 data).

    ``t``, ``p`` and ``p_holm`` have shape (methods, methods, stages); entry ``[i, j, s]``
    tests ``methods[i]`` against ``methods[j]`` at stage ``s`` (``t > 0``: ``i`` is better).
    ``t`` is antisymmetric and ``p`` symmetric in ``i, j``; the diagonal is NaN.
    """

    methods: tuple[str, ...]
    t: Array
    p: Array
    p_holm: Array

    def tile(self, method_a: str, method_b: str, adjusted: bool = False) -> Array:
        """``-log10(p) * sign(t)`` of ``method_a`` vs ``method_b`` over stages (one tile row)."""
        i, j = self._index(method_a, "method_a"), self._index(method_b, "method_b")
        if i == j:
            raise ValueError(f"method_a and method_b are both {method_a!r}; pick two methods")
        p = self.p_holm if adjusted else self.p
        return np.atleast_1d(signed_log_p(self.t[i, j], p[i, j]))

    def records(self) -> Iterator[dict]:
        """One dict per ordered pair (a != b) and stage, ready for a CSV writer."""
        for i, a in enumerate(self.methods):
            for j, b in enumerate(self.methods):
                if i == j:
                    continue
                for s in range(self.t.shape[2]):
                    yield {
                        "method_a": a,
                        "method_b": b,
                        "stage": s,
                        "t": float(self.t[i, j, s]),
                        "p": float(self.p[i, j, s]),
                        "p_holm": float(self.p_holm[i, j, s]),
                    }

    def _index(self, method: str, name: str) -> int:
        if method not in self.methods:
            raise ValueError(f"{name}={method!r} is not one of {self.methods}")
        return self.methods.index(method)


def pairwise_welch(
    results: Mapping[str, Array], holm_family: Literal["all", "stage"] = "all"
) -> PairwiseWelch:
    """Welch t-test of every pair of methods at every stage, with Holm-adjusted p-values.

    ``results`` maps a method name to its scores, shape (seeds, stages) (1-D is one stage);
    seed counts may differ between methods, stage counts may not. Each unordered pair is one
    test (A vs B and B vs A share p), so the Holm family is the ``M(M-1)/2`` pairs times all
    stages (``holm_family="all"``, the conservative default) or the pairs within each stage
    (``"stage"``).
    """
    if not isinstance(results, Mapping) or len(results) < 2:
        raise ValueError("results must be a mapping of at least two method names to scores")
    if holm_family not in ("all", "stage"):
        raise ValueError(f"holm_family must be 'all' or 'stage', got {holm_family!r}")
    methods = tuple(results)
    scores = [_run_by_task(results[m], f"results[{m!r}]", MIN_RUNS_T_TEST) for m in methods]
    n_stages = {s.shape[1] for s in scores}
    if len(n_stages) != 1:
        raise ValueError(f"results must all have the same number of stages, got {n_stages}")
    shape = (len(methods), len(methods), n_stages.pop())
    t, p = np.full(shape, np.nan), np.full(shape, np.nan)
    upper = np.triu_indices(len(methods), k=1)
    for i, j in zip(*upper, strict=True):
        t[i, j], p[i, j] = welch_t(scores[i], scores[j])
        t[j, i], p[j, i] = -t[i, j], p[i, j]
    pairs = p[upper]  # (pairs, stages)
    adj_pairs = (
        holm(pairs)
        if holm_family == "all"
        else np.stack([holm(pairs[:, s]) for s in range(shape[2])], axis=1)
    )
    p_holm = np.full(shape, np.nan)
    p_holm[upper] = adj_pairs
    p_holm[upper[1], upper[0]] = adj_pairs
    return PairwiseWelch(methods=methods, t=t, p=p, p_holm=p_holm)


# ------------------------------------------------------------------- robust aggregates


def iqm(x) -> float:
    """Interquartile mean: the mean of the middle 50% of all entries (25% trimmed each end).

    Flattens runs (and tasks) first, exactly ``scipy.stats.trim_mean(x, 0.25, axis=None)`` —
    the aggregate ``rliable`` recommends: robust to outlier runs, less noisy than the median.
    """
    return float(sps.trim_mean(_runs(x, "x"), IQM_TRIM, axis=None))


def _bootstrap_one(scores: Array, statistic: Callable, n_boot: int, ci: float, seed: int):
    n_runs, n_tasks = scores.shape
    rng = np.random.default_rng(seed)
    runs = rng.integers(0, n_runs, size=(n_boot, n_runs, n_tasks))
    resampled = scores[runs, np.arange(n_tasks)]  # runs resampled within each task column
    replicates = np.array([float(statistic(r)) for r in resampled])
    alpha = (1.0 - ci) / 2.0
    low, high = np.quantile(replicates, [alpha, 1.0 - alpha])
    return ConfidenceInterval(float(statistic(scores)), float(low), float(high))


def stratified_bootstrap_ci(
    scores,
    statistic: Callable[[Array], float] = iqm,
    n_boot: int = 2000,
    ci: float = 0.95,
    seed: int = 0,
) -> ConfidenceInterval | dict[str, ConfidenceInterval]:
    """Percentile-bootstrap confidence interval of ``statistic`` (Agarwal et al. 2021).

    ``scores`` is an array (runs, tasks) — 1-D is one task — or a mapping of method name to
    such arrays. Each replicate resamples runs with replacement *within each task* (stratified
    bootstrap, as ``rliable.StratifiedBootstrap``) and applies ``statistic`` to the resampled
    (runs, tasks) array; the interval is the ``(1-ci)/2`` and ``(1+ci)/2`` quantiles of the
    ``n_boot`` replicates. Every method uses the same ``seed``, so results do not depend on
    dict order and are reproducible.

    Returns a :class:`ConfidenceInterval` ``(estimate, low, high)``, or a dict of them.
    """
    if not callable(statistic):
        raise ValueError(f"statistic must be callable, got {type(statistic).__name__}")
    if isinstance(n_boot, bool) or not isinstance(n_boot, int | np.integer) or n_boot < 1:
        raise ValueError(f"n_boot must be a positive integer, got {n_boot!r}")
    if not 0.0 < ci < 1.0:
        raise ValueError(f"ci must lie in the open interval (0, 1), got {ci!r}")
    if isinstance(scores, Mapping):
        if not scores:
            raise ValueError("scores must not be an empty mapping")
        return {
            k: _bootstrap_one(_run_by_task(v, f"scores[{k!r}]"), statistic, n_boot, ci, seed)
            for k, v in scores.items()
        }
    return _bootstrap_one(_run_by_task(scores, "scores"), statistic, n_boot, ci, seed)


def probability_of_improvement(x, y) -> float:
    """``P(X > Y) + 0.5 P(X = Y)`` for a random run X of ``x`` and Y of ``y``.

    The Mann–Whitney ``U / (n m)`` statistic. For 2-D (runs, tasks) inputs it is computed per
    task and averaged over tasks, as in ``rliable``; run counts may differ, task counts may
    not. 1 means every run of ``x`` beats every run of ``y``; 0.5 means no preference.
    """
    x, y = _run_by_task(x, "x"), _run_by_task(y, "y")
    if x.shape[1] != y.shape[1]:
        raise ValueError(
            f"x and y must have the same number of tasks, got {x.shape[1]} and {y.shape[1]}"
        )
    gt = (x[:, None, :] > y[None, :, :]).mean(axis=(0, 1))
    eq = (x[:, None, :] == y[None, :, :]).mean(axis=(0, 1))
    return float(np.mean(gt + TIE_WEIGHT * eq))


def summarize(x, n_boot: int = 2000, ci: float = 0.95, seed: int = 0) -> dict[str, float]:
    """Report line for one method: ``mean``, ``std``, ``iqm``, ``ci_low``, ``ci_high``, ``n``.

    ``x`` is (runs,) or (runs, tasks). ``mean``/``std`` are over all entries, ``std`` the sample
    standard deviation (ddof = 1; NaN for a single entry). ``ci_low``/``ci_high`` bound the IQM
    by :func:`stratified_bootstrap_ci`. ``n`` is the number of runs.
    """
    arr = _run_by_task(x, "x")
    interval = stratified_bootstrap_ci(arr, iqm, n_boot=n_boot, ci=ci, seed=seed)
    std = float(arr.std(ddof=1)) if arr.size > 1 else float("nan")
    return {
        "mean": float(arr.mean()),
        "std": std,
        "iqm": interval.estimate,
        "ci_low": interval.low,
        "ci_high": interval.high,
        "n": int(arr.shape[0]),
    }
