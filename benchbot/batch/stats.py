"""The statistics of ``benchbot report``: intervals, paired tests, effect sizes, corrections and sim-vs-real
predictivity, each refused (with the reason) below a stated minimum sample size (docs/report.md, "Statistics").
The project's one statistics policy: sweeps' robustness curves (:mod:`benchbot.batch.sweep`) and the leaderboard
use these functions too.

**The unit of analysis.** Episodes are nested in environments, and most of the variance of a score lies between
environments (rooms differ more than repetitions in one room), so episodes of one environment are not independent
draws: an interval or a test that treats them as such is too narrow (pseudo-replication). :func:`cluster_mean_ci`
and :func:`cluster_paired_test` make the environment the unit — each environment's mean counts once, intervals and
tests run over the k environment means (resampling environments: a cluster bootstrap) — and are what reports,
sweeps and the leaderboard lead with. :func:`mean_ci` and :func:`paired_test` over episodes remain for what they
are good for: one environment's repetitions, and the episode level shown beside the environment level ("how
precisely were these environments measured", not "how does the solution do on others").

**The interval's method depends on n** (:data:`T_INTERVAL_BELOW`): Student's t interval for fewer values, the BCa
bootstrap from there on. At the n a batch usually has (5–9 environments or episodes) the BCa bootstrap covers the
mean only 83–90 % of the time instead of 95 %; Student's t keeps 93–95 % on normal and score-like (Beta) data. The
coverage simulation in ``tests/test_report_stats.py`` fails when it drops below 93 %.

Every interval and test comes from SciPy (``scipy.stats.t``, ``bootstrap``, ``ttest_rel``, ``wilcoxon``, ``pearsonr``,
``spearmanr``); what SciPy does not provide is written out here from its published definition: the Holm–Bonferroni
adjustment (Holm 1979), the matched-pairs rank-biserial correlation (Kerby 2014), the Bonett–Wright interval of
Spearman's ρ (Bonett & Wright 2000) and the mean maximum rank violation (Li et al. 2024). Resampling is seeded
(:data:`SEED`), so a report is the same every time it is made.

Every function returns plain floats (or None with a ``reason``), never NumPy scalars.
"""

from __future__ import annotations

import functools
import math
import warnings
from dataclasses import asdict, dataclass
from typing import Sequence

import numpy as np

CONFIDENCE = 0.95
"""Confidence level of every interval."""

BOOTSTRAP_RESAMPLES = 10_000
"""Resamples of every bootstrap interval."""

SEED = 0
"""Seed of every bootstrap (``numpy.random.default_rng(SEED)``): the same data give the same interval."""

MIN_CI_N = 5
"""No confidence interval of a mean from fewer values (episodes, or environments at the environment level): Student's
t interval from 4 values or fewer rests entirely on a normality nothing can check (and t₀.₉₇₅ with 3 degrees of
freedom is 3.18, so the interval spans most of the score's range), and a bootstrap can only draw C(2n−1, n) distinct
resamples (n = 2: 3, n = 3: 10, n = 4: 35; n = 5: 126)."""

T_INTERVAL_BELOW = 30
"""Below this many values the interval of a mean is Student's t interval (``scipy.stats.t.interval``); from it on,
the BCa bootstrap. Measured coverage of a nominal 95 % interval (``tests/test_report_stats.py``, 10,000 data sets
per case): Student's t 94.7–95.3 % on normal data and 93.3–94.0 % on Beta(2, 5) data at n = 5–9; BCa 83 % at n = 5
and 90 % at n = 9, and (600 data sets per case) still 91–94 % at n = 15–30, where Student's t keeps 93–96 %."""

MIN_TEST_PAIRS = 6
"""No paired test from fewer pairs: the smallest two-sided p-value the Wilcoxon signed-rank test can give with n
pairs is 2/2ⁿ (n = 5: 0.0625), so below 6 pairs it cannot reach 0.05 whatever the data; the t-test with so few
pairs rests on a normality of the differences that nothing can check."""

MIN_CORRELATION_N = 5
"""No interval or p-value of a correlation (or of MMRV) from fewer paired units: Fisher's z interval needs n > 3,
and with 4 units the smallest two-sided permutation p-value of a rank correlation is 2/4! ≈ 0.083."""

MIN_RANK_N = 3
"""No correlation at all from fewer paired units: with 2 points any correlation is ±1 by construction."""


@dataclass
class Estimate:
    """A statistic with its interval, or the reason it has none.

    Attributes:
        n: the number of values (or pairs, or units) it was computed from.
        value: the point estimate (None when it cannot be computed at all).
        low, high: the ``CONFIDENCE`` interval, or None (then ``reason`` says why).
        reason: why there is no interval (or no value), in words; "" when there is one.
        method: how the interval was made, in words.
        level: what ``n`` counts: ``"episodes"``, ``"environments"``, ``"pairs"`` (of episodes) or
            ``"environment pairs"``; "" when not said.
    """

    n: int
    value: float | None
    low: float | None = None
    high: float | None = None
    reason: str = ""
    method: str = ""
    level: str = ""

    def to_json(self) -> dict:
        """The fields as a dict."""
        return asdict(self)


def _float(x) -> float | None:
    return None if x is None or not math.isfinite(float(x)) else float(x)


def _too_few(n: int, minimum: int, what: str) -> str:
    return f"n = {n} < {minimum}: no {what}"


def _bootstrap(data: tuple, statistic, *, paired: bool = False, method: str = "BCa",
               vectorized: bool = False) -> tuple[float | None, float | None, str]:
    """``scipy.stats.bootstrap`` with this module's settings → ``(low, high, reason)``."""
    from scipy import stats

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # degenerate data: reported as a reason below
        try:
            res = stats.bootstrap(data, statistic, n_resamples=BOOTSTRAP_RESAMPLES, confidence_level=CONFIDENCE,
                                  method=method, paired=paired, vectorized=vectorized,
                                  rng=np.random.default_rng(SEED))
        except ValueError as exc:
            return None, None, f"no interval: {exc}"
    low, high = _float(res.confidence_interval.low), _float(res.confidence_interval.high)
    if low is None or high is None:
        return None, None, "no interval: the resamples do not vary (every value is equal)"
    return low, high, ""


def interval_method(n: int) -> str:
    """``"t"`` below :data:`T_INTERVAL_BELOW` values, else ``"bca"``: the method :func:`mean_ci` picks."""
    return "t" if n < T_INTERVAL_BELOW else "bca"


@functools.lru_cache(maxsize=256)
def _t_quantile(df: int) -> float:
    """Student's t quantile ``t_{(1 + CONFIDENCE)/2, df}`` (``scipy.stats.t.ppf``), once per ``df``."""
    from scipy import stats

    return float(stats.t.ppf(0.5 + CONFIDENCE / 2, df))


def _t_interval(x: np.ndarray) -> tuple[float | None, float | None]:
    """Student's t interval of the mean of ``x``: mean ± t_{(1 + CONFIDENCE)/2, n−1} · s / √n (the interval
    ``scipy.stats.t.interval`` gives; the tests check they agree)."""
    mean, half = float(x.mean()), _t_quantile(int(x.size) - 1) * float(x.std(ddof=1)) / math.sqrt(x.size)
    return _float(mean - half), _float(mean + half)


def mean_ci(values: Sequence[float], *, method: str = "auto", level: str = "") -> Estimate:
    """The mean of ``values`` with its :data:`CONFIDENCE` interval: Student's t interval below
    :data:`T_INTERVAL_BELOW` values, else the bias-corrected and accelerated (BCa) bootstrap
    (``scipy.stats.bootstrap``, :data:`BOOTSTRAP_RESAMPLES` resamples, seed :data:`SEED`).

    Args:
        values: ``(n,)`` finite numbers (scores in [0, 1] here), independent draws of what the interval is about.
        method: ``"auto"`` (by n, as above), ``"t"`` or ``"bca"`` (forced: the coverage tests compare them).
        level: what the values are (``"episodes"``, ``"environments"``...), kept in the estimate.

    Returns:
        an :class:`Estimate`; no interval when n < :data:`MIN_CI_N` or every value is equal (the reason says which);
        ``value`` None when there are no values.

    Raises:
        ValueError: an unknown ``method``.
    """
    if method not in ("auto", "t", "bca"):
        raise ValueError(f"unknown interval method {method!r}")
    x = np.asarray(values, dtype=np.float64)
    if x.size == 0:
        return Estimate(0, None, reason="no values", level=level)
    chosen = interval_method(int(x.size)) if method == "auto" else method
    est = Estimate(int(x.size), float(x.mean()), level=level,
                   method=f"Student t (n < {T_INTERVAL_BELOW})" if chosen == "t" and method == "auto" else
                   "Student t" if chosen == "t" else f"BCa bootstrap, {BOOTSTRAP_RESAMPLES} resamples")
    if x.size < MIN_CI_N:
        est.reason = _too_few(int(x.size), MIN_CI_N, "confidence interval")
        return est
    if np.all(x == x[0]):
        est.low = est.high = float(x[0])
        est.reason = "every value is equal: the interval is the value itself"
        return est
    if chosen == "t":
        est.low, est.high = _t_interval(x)
    else:
        est.low, est.high, est.reason = _bootstrap((x,), np.mean, vectorized=True)
    return est


def cluster_means(values: Sequence[float], clusters: Sequence) -> dict:
    """``{cluster: mean of its values}`` in first-seen order (``values[i]`` belongs to ``clusters[i]``).

    Raises:
        ValueError: ``values`` and ``clusters`` differ in length.
    """
    if len(values) != len(clusters):
        raise ValueError(f"values and clusters differ in length: {len(values)} and {len(clusters)}")
    groups: dict = {}
    for v, c in zip(values, clusters):
        groups.setdefault(c, []).append(float(v))
    return {c: float(np.mean(v)) for c, v in groups.items()}


def cluster_mean_ci(values: Sequence[float], clusters: Sequence) -> Estimate:
    """The mean with the environment (cluster) as the unit: the mean over the k clusters of each cluster's mean
    (every environment counts once, however many episodes it had), its interval over those k means (:func:`mean_ci`:
    Student's t below :data:`T_INTERVAL_BELOW` clusters, else the BCa bootstrap of the cluster means, which is the
    cluster bootstrap of this statistic: resampling environments with all their episodes). Episodes are not
    resampled within a cluster: each cluster mean already carries its within-cluster noise, and resampling it again
    would count that noise twice (Davison & Hinkley 1997, *Bootstrap Methods and their Application*, §3.8).

    Args:
        values: ``(n,)`` one value per episode. clusters: ``(n,)`` the environment of each.

    Returns:
        an :class:`Estimate` with ``n`` = k clusters and ``level`` ``"environments"``; no interval below
        :data:`MIN_CI_N` clusters (the reason says so).
    """
    est = mean_ci(list(cluster_means(values, clusters).values()), level="environments")
    if est.reason.startswith("n = "):
        est.reason = est.reason.replace("no confidence interval", "no confidence interval over environments")
    return est


def holm(pvalues: Sequence[float | None]) -> list[float | None]:
    """Holm–Bonferroni adjusted p-values (Holm 1979, "A simple sequentially rejective multiple test procedure"):
    with the m p-values sorted ascending, the i-th (1-based) becomes ``max over j ≤ i of min(1, (m − j + 1) p_(j))``.
    Rejecting where the adjusted p < α controls the family-wise error rate at α. ``None`` entries (tests not run)
    are kept as None and are not counted in m.

    Args:
        pvalues: one p-value (or None) per comparison of the family.

    Returns:
        the adjusted p-values, in the input order.
    """
    index = [i for i, p in enumerate(pvalues) if p is not None]
    order = sorted(index, key=lambda i: pvalues[i])
    m = len(order)
    out: list[float | None] = [None] * len(pvalues)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * float(pvalues[i])))
        out[i] = running
    return out


def rank_biserial(differences: Sequence[float]) -> float | None:
    """The matched-pairs rank-biserial correlation of paired differences (Kerby 2014, "The simple difference
    formula"): ``(R+ − R−) / (R+ + R−)``, the rank sums (average ranks of |d|) of the positive and the negative
    differences, zeros dropped as in the Wilcoxon test. In [−1, 1]; None when every difference is 0."""
    from scipy.stats import rankdata

    d = np.asarray(differences, dtype=np.float64)
    d = d[d != 0]
    if d.size == 0:
        return None
    ranks = rankdata(np.abs(d))
    plus, minus = ranks[d > 0].sum(), ranks[d < 0].sum()
    return float((plus - minus) / (plus + minus))


def paired_test(a: Sequence[float], b: Sequence[float], *, level: str = "pairs") -> dict:
    """Compare paired values ``b`` against ``a`` (pair i is ``a[i]``, ``b[i]``: the same environment and seed, or
    the same environment's means).

    Args:
        a, b: ``(n,)`` paired values. level: what a pair is (``"pairs"`` of episodes, ``"environment pairs"``),
            kept in the difference's estimate and in the result.

    Returns:
        ``{n, level, difference: Estimate (mean of b − a, its interval by :func:`mean_ci`), cohens_dz,
        rank_biserial, ttest_p, wilcoxon_p, reason}``: ``cohens_dz`` = mean(d) / sd(d) (the standardised mean
        difference of paired data, Cohen 1988; None when sd = 0), ``ttest_p`` from ``scipy.stats.ttest_rel``,
        ``wilcoxon_p`` from ``scipy.stats.wilcoxon`` (zeros dropped; exact for small n without ties). Below
        :data:`MIN_TEST_PAIRS` pairs no test and no interval are made and ``reason`` says why; the mean difference
        is still given.

    Raises:
        ValueError: ``a`` and ``b`` differ in length.
    """
    from scipy import stats

    xa, xb = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if xa.shape != xb.shape:
        raise ValueError(f"paired values differ in length: {xa.size} and {xb.size}")
    d = xb - xa
    n = int(d.size)
    out = {"n": n, "level": level, "difference": Estimate(n, float(d.mean()) if n else None, level=level),
           "cohens_dz": None, "rank_biserial": None, "ttest_p": None, "wilcoxon_p": None, "reason": ""}
    if n < MIN_TEST_PAIRS:
        out["reason"] = _too_few(n, MIN_TEST_PAIRS, "paired test")
        if level == "environment pairs":
            out["reason"] += " over environments"
        out["difference"].reason = out["reason"]
        return out
    out["difference"] = mean_ci(d, level=level)
    sd = float(d.std(ddof=1))
    out["cohens_dz"] = float(d.mean() / sd) if sd > 0 else None
    out["rank_biserial"] = rank_biserial(d)
    if np.all(d == 0):
        out["ttest_p"] = out["wilcoxon_p"] = 1.0
        out["reason"] = "every difference is 0"
        return out
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # exact-distribution notes on ties
        out["ttest_p"] = _float(stats.ttest_rel(xb, xa).pvalue) if sd > 0 else None
        out["wilcoxon_p"] = _float(stats.wilcoxon(xb, xa).pvalue)
    return out


def cluster_paired_test(a: Sequence[float], b: Sequence[float], clusters: Sequence) -> dict:
    """:func:`paired_test` with the environment as the unit: the paired episodes (``a[i]``, ``b[i]`` of environment
    ``clusters[i]``) are averaged per environment, and the k environments' means are compared pair by pair (the
    t-test and Wilcoxon test over k environment differences, not over the episodes, which are not independent
    within an environment).

    Returns:
        :func:`paired_test`'s dict with ``n`` = k environments, ``level`` ``"environment pairs"``, plus
        ``clusters`` (the environments in order) and ``cluster_differences`` (b − a per environment).

    Raises:
        ValueError: ``a``, ``b`` and ``clusters`` differ in length.
    """
    if not len(a) == len(b) == len(clusters):
        raise ValueError(f"paired values and clusters differ in length: {len(a)}, {len(b)}, {len(clusters)}")
    ma, mb = cluster_means(a, clusters), cluster_means(b, clusters)
    out = paired_test(list(ma.values()), list(mb.values()), level="environment pairs")
    out["clusters"] = [str(c) for c in ma]
    out["cluster_differences"] = [mb[c] - ma[c] for c in ma]
    return out


def mmrv(sim: Sequence[float], real: Sequence[float]) -> float:
    """Mean maximum rank violation (Li et al. 2024, "Evaluating Real-World Robot Manipulation Policies in
    Simulation", SimplerEnv, arXiv:2405.05941), exactly as defined there::

        RV(i, j) = |R_i − R_j| · 1[(S_i > S_j) ≠ (R_i > R_j)]
        MMRV     = (1/N) Σ_i max_j RV(i, j)

    where S is the performance in the first setting (simulation) and R in the second (the real robot) of N paired
    units (policies, solutions, environments). Each unit contributes its worst ordering mistake, weighted by how far
    apart the two units really are; 0 when simulation orders every pair as reality does. The comparisons are
    strict, so a tie in one setting against an order in the other counts as a violation (for one unit of the pair).

    Args:
        sim, real: ``(N,)`` performances (same scale in both, e.g. OMQ in [0, 1]).

    Returns:
        MMRV in the units of ``real`` (0 ≤ MMRV ≤ max(real) − min(real)).

    Raises:
        ValueError: different lengths, or fewer than 2 units.
    """
    s, r = np.asarray(sim, dtype=np.float64), np.asarray(real, dtype=np.float64)
    if s.shape != r.shape or s.ndim != 1:
        raise ValueError(f"sim and real must be paired 1-D sequences, got {s.shape} and {r.shape}")
    if s.size < 2:
        raise ValueError("MMRV needs at least 2 paired units")
    violated = (s[:, None] > s[None, :]) != (r[:, None] > r[None, :])
    rv = np.abs(r[:, None] - r[None, :]) * violated
    return float(rv.max(axis=1).mean())


def _mmrv_statistic(s: np.ndarray, r: np.ndarray) -> float:
    return mmrv(s, r)


def spearman_ci(rho: float, n: int) -> tuple[float | None, float | None]:
    """The Bonett–Wright interval of Spearman's ρ (Bonett & Wright 2000, "Sample size requirements for estimating
    Pearson, Kendall and Spearman correlations"): Fisher's z = atanh(ρ) ± z_{α/2} · sqrt((1 + ρ²/2) / (n − 3)),
    transformed back with tanh. ``(None, None)`` for n ≤ 3 or |ρ| = 1."""
    from scipy.stats import norm

    if n <= 3 or abs(rho) >= 1:
        return None, None
    half = norm.ppf(0.5 + CONFIDENCE / 2) * math.sqrt((1 + rho * rho / 2) / (n - 3))
    z = math.atanh(rho)
    return math.tanh(z - half), math.tanh(z + half)


def predictivity(sim: Sequence[float], real: Sequence[float]) -> dict:
    """How well the first setting (simulation) predicts the second (the real robot) over N paired units.

    * ``spearman``: Spearman's rank correlation ρ (``scipy.stats.spearmanr``), Bonett–Wright interval
      (:func:`spearman_ci`), p-value of ρ = 0 (t approximation).
    * ``pearson``: Pearson's r (``scipy.stats.pearsonr``), Fisher z interval, p-value of r = 0. Pearson's r over
      paired sim and real performances is the "Sim-vs-Real Correlation Coefficient" (SRCC) of Kadian et al. 2020,
      "Sim2Real Predictivity: Does Evaluation in Simulation Predict Real-World Performance?" (IEEE RA-L 5(4),
      arXiv:1912.06321).
    * ``mmrv``: :func:`mmrv`, with a percentile bootstrap interval over the units (``scipy.stats.bootstrap``,
      paired resampling).

    No correlation below :data:`MIN_RANK_N` units, no interval or p-value below :data:`MIN_CORRELATION_N`; a
    setting whose values are all equal has no correlation (its ``reason`` says so).

    Args:
        sim, real: ``(N,)`` paired performances.

    Returns:
        ``{n, spearman: Estimate + p, pearson: Estimate + p, mmrv: Estimate}`` as dicts (``p`` None where refused).

    Raises:
        ValueError: ``sim`` and ``real`` differ in length.
    """
    from scipy import stats

    s, r = np.asarray(sim, dtype=np.float64), np.asarray(real, dtype=np.float64)
    if s.shape != r.shape:
        raise ValueError(f"sim and real differ in length: {s.size} and {r.size}")
    n = int(s.size)
    out: dict = {"n": n}
    for key in ("spearman", "pearson"):
        est = {**Estimate(n, None).to_json(), "p": None}
        if n < MIN_RANK_N:
            est["reason"] = _too_few(n, MIN_RANK_N, "correlation")
        elif np.all(s == s[0]) or np.all(r == r[0]):
            est["reason"] = "one setting gives every unit the same value: no correlation"
        else:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = stats.spearmanr(s, r) if key == "spearman" else stats.pearsonr(s, r)
            est["value"] = _float(res.statistic)
            if n < MIN_CORRELATION_N:
                est["reason"] = _too_few(n, MIN_CORRELATION_N, "interval or p-value")
            else:
                est["p"] = _float(res.pvalue)
                if key == "spearman":
                    est["low"], est["high"] = spearman_ci(est["value"], n)
                    est["method"] = "Bonett–Wright (Fisher z) interval"
                else:
                    ci = res.confidence_interval(confidence_level=CONFIDENCE)
                    est["low"], est["high"] = _float(ci.low), _float(ci.high)
                    est["method"] = "Fisher z interval"
                if est["low"] is None:
                    est["reason"] = "no interval for a perfect correlation (|value| = 1)"
        out[key] = est
    m = Estimate(n, None)
    if n < 2:
        m.reason = _too_few(n, 2, "rank violation")
    else:
        m.value = mmrv(s, r)
        if n < MIN_CORRELATION_N:
            m.reason = _too_few(n, MIN_CORRELATION_N, "interval")
        else:
            m.method = f"percentile bootstrap over units, {BOOTSTRAP_RESAMPLES} resamples"
            m.low, m.high, m.reason = _bootstrap((s, r), _mmrv_statistic, paired=True, method="percentile")
    out["mmrv"] = m.to_json()
    return out


# --------------------------------------------------------------------------------------------------------------------
# Bounded scores
# --------------------------------------------------------------------------------------------------------------------
def clip_to_range(estimate: Estimate, low: float | None, high: float | None) -> Estimate:
    """``estimate`` with its interval clipped to ``[low, high]``, the range its score declares (None: unbounded on
    that side), saying so in its ``method`` when it clipped. A mean of values in [0, 1] cannot lie outside it, so
    clipping an interval at the bound removes only values the mean cannot take: it never lowers the interval's
    coverage, and keeps ``low ≤ value ≤ high``. (Student's t interval of a mean near a bound is symmetric and can
    pass it: 1.003 for an OMQ near 1.) Clipped, not transformed: a logit interval would be undefined at a mean of
    exactly 0 or 1, which a score's range allows."""
    if estimate.low is None or estimate.high is None:
        return estimate
    lo, hi = estimate.low, estimate.high
    if low is not None:
        lo, hi = max(lo, low), max(hi, low)
    if high is not None:
        lo, hi = min(lo, high), min(hi, high)
    if (lo, hi) != (estimate.low, estimate.high):
        estimate.low, estimate.high = lo, hi
        estimate.method += f"; clipped to the score's range [{low if low is not None else '−∞'}, " \
                           f"{high if high is not None else '∞'}]"
    return estimate


# --------------------------------------------------------------------------------------------------------------------
# Robust aggregates (Agarwal et al. 2021, "Deep Reinforcement Learning at the Edge of the Statistical Precipice",
# NeurIPS, arXiv:2108.13264; the rliable library's definitions, with SciPy's bootstrap)
# --------------------------------------------------------------------------------------------------------------------
def iqm(values: Sequence[float]) -> float | None:
    """The interquartile mean: the mean of the middle 50 % of ``values`` (``scipy.stats.trim_mean(values, 0.25)``,
    which drops ⌊n/4⌋ values at each end, as rliable's ``aggregate_iqm`` does); None for no values. Robust to a few
    outlying values (a room where everything fails), and less noisy than the median (Agarwal et al. 2021)."""
    from scipy import stats

    x = np.asarray(values, dtype=np.float64)
    return None if x.size == 0 else float(stats.trim_mean(x, 0.25))


def _strata(groups: Sequence[Sequence[float]]) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """``(resampled, fixed)``: the groups with two or more values (SciPy's bootstrap resamples them) and those with
    one (a stratum of one value resamples to itself)."""
    arrays = [np.asarray(g, dtype=np.float64) for g in groups if len(g)]
    return [a for a in arrays if a.size > 1], [a for a in arrays if a.size == 1]


def _stratified(groups: list[list[np.ndarray]], statistic, *, multi: bool = False) -> tuple:
    """A percentile interval of ``statistic`` by the stratified bootstrap: every group of values (one per
    environment and run) resampled with replacement within itself, independently (``scipy.stats.bootstrap`` with
    one sample per stratum, which resamples each sample on its own: rliable's ``StratifiedBootstrap``).

    Args:
        groups: per stratum kind (e.g. the runs), a list of ``(n_k,)`` arrays, one per environment; every kind has
            the same environments in the same order.
        statistic: ``statistic(*kinds)`` where each kind is a list of arrays ``(..., n_k)``, returning ``(...)``
            (or ``(k, ...)`` with ``multi``).

    Returns:
        ``(low, high, reason)``; reason says why there is no interval (no stratum has two values).
    """
    from scipy import stats

    flat = [a for kind in groups for a in kind]
    movable = [i for i, a in enumerate(flat) if a.size > 1]
    if not movable:
        return None, None, "every environment has one episode: a stratified bootstrap has nothing to resample"
    sizes = [len(kind) for kind in groups]

    def vectorised(*samples, axis=-1):
        batch = samples[0].shape[:-1]
        arrays = list(flat)
        for i, sample in zip(movable, samples):
            arrays[i] = sample
        arrays = [a if a.ndim > 1 or i in movable else np.broadcast_to(a, batch + a.shape)
                  for i, a in enumerate(arrays)]
        kinds, start = [], 0
        for size in sizes:
            kinds.append(arrays[start:start + size])
            start += size
        return statistic(*kinds)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = stats.bootstrap(tuple(flat[i] for i in movable), vectorised, n_resamples=BOOTSTRAP_RESAMPLES,
                              confidence_level=CONFIDENCE, method="percentile", vectorized=True,
                              rng=np.random.default_rng(SEED))
    low, high = res.confidence_interval.low, res.confidence_interval.high
    if multi:
        return np.asarray(low, dtype=float), np.asarray(high, dtype=float), ""
    return _float(low), _float(high), ""


def iqm_environments(groups: Sequence[Sequence[float]]) -> Estimate:
    """The IQM over environments (the unit): :func:`iqm` of the environments' means, with a percentile bootstrap
    interval over the environments (``scipy.stats.bootstrap``; resampling environments with all their episodes,
    as :func:`cluster_mean_ci` does); none below :data:`MIN_CI_N` environments.

    Args:
        groups: one sequence of episode scores per environment.
    """
    means = [float(np.mean(g)) for g in groups if len(g)]
    est = Estimate(len(means), iqm(means), level="environments",
                   method=f"IQM of the environments' means; percentile bootstrap over environments, "
                          f"{BOOTSTRAP_RESAMPLES} resamples")
    if len(means) < MIN_CI_N:
        est.reason = _too_few(len(means), MIN_CI_N, "confidence interval over environments")
    elif len(set(means)) == 1:
        est.low = est.high = means[0]
        est.reason = "every value is equal: the interval is the value itself"
    else:
        from scipy import stats

        est.low, est.high, est.reason = _bootstrap((np.asarray(means),), lambda x, axis=-1: stats.trim_mean(
            x, 0.25, axis=axis), method="percentile", vectorized=True)
    return est


def iqm_stratified(groups: Sequence[Sequence[float]]) -> Estimate:
    """rliable's IQM: :func:`iqm` of every episode's score pooled over the environments, with the stratified
    bootstrap's percentile interval (episodes resampled within each environment, :func:`_stratified`). The
    environments are held fixed: the interval says how precisely *these* environments were measured (as rliable's
    runs of a fixed set of tasks), not how the solution does on other environments (:func:`iqm_environments`).
    With unequal repetitions, an environment with more episodes weighs more (rliable assumes equal ones).

    Args:
        groups: one sequence of episode scores per environment.
    """
    from scipy import stats

    moved, fixed = _strata(groups)
    pooled = [float(v) for g in groups for v in g]
    est = Estimate(len(pooled), iqm(pooled), level="episodes",
                   method=f"IQM of the episodes; stratified bootstrap (episodes within environments), percentile, "
                          f"{BOOTSTRAP_RESAMPLES} resamples")
    if len(pooled) < MIN_CI_N:
        est.reason = _too_few(len(pooled), MIN_CI_N, "confidence interval")
        return est

    def statistic(kind):
        batch = np.broadcast_shapes(*(a.shape[:-1] for a in kind))
        return stats.trim_mean(np.concatenate([np.broadcast_to(a, batch + a.shape[-1:]) for a in kind], axis=-1),
                               0.25, axis=-1)

    est.low, est.high, est.reason = _stratified([moved + fixed], statistic)
    return est


def _improvement(a_kind: list[np.ndarray], b_kind: list[np.ndarray]) -> np.ndarray:
    """The mean over environments of P(b > a) within each (ties count one half): ``(...)`` from arrays
    ``(..., n)``."""
    per_env = []
    for a, b in zip(a_kind, b_kind):
        diff = b[..., :, None] - a[..., None, :]
        per_env.append(np.mean((diff > 0) + 0.5 * (diff == 0), axis=(-2, -1)))
    return np.mean(np.broadcast_arrays(*per_env), axis=0)


def probability_of_improvement(a: Sequence[Sequence[float]], b: Sequence[Sequence[float]], sign: int = 1) -> Estimate:
    """Agarwal et al. 2021's probability of improvement of run B over run A: per environment m, the probability that
    an episode of B scores better than one of A, P_m = (1 / (N_a N_b)) Σ_i Σ_j S(b_j, a_i) with S = 1 when better,
    ½ when equal, 0 otherwise (the Mann–Whitney U statistic over N_a N_b), averaged over the environments, each
    counting once. 0.5: neither is better; above: B better. Its interval is rliable's, the stratified bootstrap
    (each run's episodes resampled within each environment, :func:`_stratified`): about these environments, like
    every stratified-bootstrap interval.

    Args:
        a, b: per environment (the same ones in the same order), the episode scores of run A and of run B.
        sign: +1 when higher is better, −1 when lower is.

    Raises:
        ValueError: ``a`` and ``b`` have different numbers of environments.
    """
    if len(a) != len(b):
        raise ValueError(f"a and b differ in environments: {len(a)} and {len(b)}")
    pairs = [(np.asarray(x, float) * sign, np.asarray(y, float) * sign) for x, y in zip(a, b) if len(x) and len(y)]
    est = Estimate(len(pairs), None, level="environments",
                   method=f"stratified bootstrap (episodes within environments), percentile, "
                          f"{BOOTSTRAP_RESAMPLES} resamples")
    if not pairs:
        est.reason = "no environment both runs ran"
        return est
    est.value = float(_improvement([p[0] for p in pairs], [p[1] for p in pairs]))
    est.low, est.high, est.reason = _stratified([[p[0] for p in pairs], [p[1] for p in pairs]], _improvement)
    return est


def score_distribution(groups: Sequence[Sequence[float]], taus: Sequence[float]) -> dict:
    """rliable's score distribution (its "performance profile" of run scores): for each threshold τ, the fraction
    of episodes scoring above τ, averaged over the environments (each counts once), with a 95 % band by the
    stratified bootstrap (episodes within environments, percentile, pointwise). It shows the whole distribution
    rather than one aggregate: one profile above another everywhere is stochastic dominance.

    Args:
        groups: one sequence of episode scores per environment. taus: ``(k,)`` thresholds.

    Returns:
        ``{"taus": [k], "fraction": [k], "low": [k] or None, "high": [k] or None, "reason"}``.
    """
    t = np.asarray(taus, dtype=np.float64)
    arrays = [np.asarray(g, dtype=np.float64) for g in groups if len(g)]

    def statistic(kind):
        out = np.mean(np.broadcast_arrays(*[np.mean(a[..., :, None] > t, axis=-2) for a in kind]), axis=0)
        return np.moveaxis(out, -1, 0)

    fraction = statistic(arrays) if arrays else np.full(t.shape, np.nan)
    out = {"taus": t.tolist(), "fraction": [float(v) for v in fraction], "low": None, "high": None, "reason": ""}
    if not arrays:
        out["reason"] = "no episodes"
        return out
    low, high, out["reason"] = _stratified([arrays], statistic, multi=True)
    if low is not None:
        out["low"], out["high"] = [float(v) for v in low], [float(v) for v in high]
    return out


# --------------------------------------------------------------------------------------------------------------------
# How many environments: planning from a pilot
# --------------------------------------------------------------------------------------------------------------------
PLAN_SD_LEVEL = 0.8
"""The one-sided confidence level of the upper bound on the pilot's SD that the cautious plan uses (Browne 1995)."""

PLAN_POWER = 0.8
"""The power a plan for a detectable difference asks for (the conventional 80 %), at a two-sided α of
1 − :data:`CONFIDENCE`."""

PLAN_MAX = 100_000
"""Plans needing more environments than this are reported as "more than" it."""

MIN_PILOT_N = 3
"""No plan from fewer pilot environments: an SD from 2 values has 1 degree of freedom, and its upper bound is 3.2
times it."""


def interval_width(sd: float, k: int) -> float:
    """The width of Student's t interval (:data:`CONFIDENCE`) of a mean of ``k`` values with standard deviation
    ``sd``: 2 · t_{(1 + CONFIDENCE)/2, k − 1} · sd / √k."""
    return 2 * _t_quantile(k - 1) * sd / math.sqrt(k)


def paired_power(sd: float, difference: float, k: int) -> float:
    """The power of the two-sided paired t-test at α = 1 − :data:`CONFIDENCE` over ``k`` pairs whose differences
    have mean ``difference`` and standard deviation ``sd``: with noncentrality δ = difference · √k / sd and
    t* = t_{1 − α/2, k − 1}, power = P(T > t*) + P(T < −t*) for T ~ noncentral t(k − 1, δ) (``scipy.stats.nct``;
    what R's ``power.t.test(type = "one.sample")`` computes)."""
    from scipy import stats

    crit = _t_quantile(k - 1)
    nc = abs(difference) * math.sqrt(k) / sd
    return float(stats.nct.sf(crit, k - 1, nc) + stats.nct.cdf(-crit, k - 1, nc))


def _smallest(ok, start: int) -> int | None:
    """The smallest k ≥ ``start`` with ``ok(k)`` (``ok`` monotone), by doubling then bisection; None beyond
    :data:`PLAN_MAX`."""
    hi = start
    while not ok(hi):
        if hi >= PLAN_MAX:
            return None
        hi = min(PLAN_MAX, hi * 2)
    lo = start
    while lo < hi:
        mid = (lo + hi) // 2
        if ok(mid):
            hi = mid
        else:
            lo = mid + 1
    return lo


def sd_upper(sd: float, n: int, level: float = PLAN_SD_LEVEL) -> float:
    """The one-sided ``level`` upper confidence limit of a standard deviation estimated from ``n`` values:
    sd · √((n − 1) / χ²_{1 − level, n − 1}) (normal data). Planning with it instead of the pilot's SD itself guards
    against a pilot that happened to vary little (Browne 1995, "On the use of a pilot sample for sample size
    determination", Statistics in Medicine 14)."""
    from scipy import stats

    return float(sd * math.sqrt((n - 1) / stats.chi2.ppf(1 - level, n - 1)))


def plan_environments(values: Sequence[float], *, width: float | None = None,
                      difference: float | None = None) -> dict:
    """How many environments a study needs, from a pilot's environment-level values: the environments' means of one
    run (for an interval ``width``) or their paired differences between two runs (for a detectable
    ``difference``).

    * ``width``: the smallest k whose Student t interval of the mean is at most ``width`` wide (:func:`interval_width`)
      with the pilot's SD — the width a study gets on average — and at least :data:`MIN_CI_N`;
    * ``difference``: the smallest k at which the paired t-test over k environments detects a mean difference of
      ``difference`` with power :data:`PLAN_POWER` (:func:`paired_power`), and at least :data:`MIN_TEST_PAIRS`.

    Each is also given for the SD's :data:`PLAN_SD_LEVEL` upper bound (:func:`sd_upper`): the cautious number.
    Both hold for environments like the pilot's, each measured as the pilot measured them (the same number of
    episodes per environment: fewer make every environment mean noisier).

    Args:
        values: ``(n,)`` one value per pilot environment. width, difference: what the study should achieve, in the
            score's units.

    Returns:
        ``{"n", "sd", "sd_upper", "width": {"target", "environments", "cautious"} or None, "difference": {...} or
        None, "reason"}`` (numbers of environments None above :data:`PLAN_MAX`; ``reason`` set and the rest None
        below :data:`MIN_PILOT_N` pilot environments or when they do not vary).

    Raises:
        ValueError: a ``width`` or ``difference`` that is not positive.
    """
    for name, target in (("width", width), ("difference", difference)):
        if target is not None and not target > 0:
            raise ValueError(f"{name} must be positive, not {target}")
    x = np.asarray(values, dtype=np.float64)
    n = int(x.size)
    out = {"n": n, "sd": None, "sd_upper": None, "width": None, "difference": None, "reason": ""}
    if n < MIN_PILOT_N:
        out["reason"] = _too_few(n, MIN_PILOT_N, "plan (the SD of so few environments says nothing)")
        return out
    sd = float(x.std(ddof=1))
    if np.all(x == x[0]):
        out["reason"] = "the pilot's environments do not vary: their SD is 0, so any number of environments would do"
        return out
    out["sd"], out["sd_upper"] = sd, sd_upper(sd, n)
    if width is not None:
        out["width"] = {"target": float(width), **{key: _smallest(lambda k, s=s: interval_width(s, k) <= width,
                                                                   MIN_CI_N)
                                                   for key, s in (("environments", sd), ("cautious", out["sd_upper"]))}}
    if difference is not None:
        out["difference"] = {"target": float(difference), "power": PLAN_POWER, **{
            key: _smallest(lambda k, s=s: paired_power(s, difference, k) >= PLAN_POWER, MIN_TEST_PAIRS)
            for key, s in (("environments", sd), ("cautious", out["sd_upper"]))}}
    return out
