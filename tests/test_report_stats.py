"""benchbot.batch.stats against reference values: published examples, hand-computed answers, the refusals below
each stated minimum, and the sim-vs-real predictivity numbers on constructed data with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats as sps

from benchbot.batch import stats

# Student's sleep data (Cushny & Peebles 1905; R's `sleep`): extra hours of sleep under two drugs, 10 patients.
# R: t.test(extra ~ group, data = sleep, paired = TRUE) -> t = -4.0621, df = 9, p-value = 0.002833, mean of the
# differences -1.58, 95 % CI [-2.4599, -0.7001].
SLEEP_1 = [0.7, -1.6, -0.2, -1.2, -0.1, 3.4, 3.7, 0.8, 0.0, 2.0]
SLEEP_2 = [1.9, 0.8, 1.1, 0.1, -0.1, 4.4, 5.5, 1.6, 4.6, 3.4]


def test_mean_ci_refuses_below_the_minimum_and_says_why():
    for n in range(1, stats.MIN_CI_N):
        est = stats.mean_ci([0.1601 + 0.01 * i for i in range(n)])
        assert est.n == n and est.low is None and est.high is None
        assert f"n = {n} < {stats.MIN_CI_N}: no confidence interval" in est.reason
    assert stats.mean_ci([]).value is None and stats.mean_ci([]).reason == "no values"
    assert stats.mean_ci([0.1601]).value == pytest.approx(0.1601)  # the mean is still given


def test_mean_ci_is_scipys_bca_bootstrap_and_agrees_with_the_t_interval_on_normal_data():
    x = np.random.default_rng(3).normal(0.3, 0.05, 200)
    est = stats.mean_ci(x)
    ref = sps.bootstrap((x,), np.mean, n_resamples=stats.BOOTSTRAP_RESAMPLES, method="BCa",
                        rng=np.random.default_rng(stats.SEED)).confidence_interval
    assert (est.low, est.high) == (pytest.approx(ref.low, abs=1e-12), pytest.approx(ref.high, abs=1e-12))
    t_low, t_high = sps.t.interval(0.95, len(x) - 1, loc=x.mean(), scale=sps.sem(x))
    assert est.low == pytest.approx(t_low, abs=0.002) and est.high == pytest.approx(t_high, abs=0.002)
    assert stats.mean_ci(x).low == est.low  # seeded: the same every time
    same = stats.mean_ci([0.2] * 6)
    assert (same.low, same.high) == (0.2, 0.2) and "every value is equal" in same.reason


def test_paired_test_on_the_sleep_data_matches_r():
    out = stats.paired_test(SLEEP_1, SLEEP_2)
    assert out["n"] == 10 and out["reason"] == ""
    assert out["difference"].value == pytest.approx(1.58)
    assert out["ttest_p"] == pytest.approx(0.002833, abs=5e-7)
    d = np.subtract(SLEEP_2, SLEEP_1)
    assert out["cohens_dz"] == pytest.approx(1.58 / 1.2299955, rel=1e-6)  # sd of the differences 1.2300 (R: sd)
    # 9 non-zero differences, all positive: exact two-sided Wilcoxon p = 2 / 2^9; rank-biserial r = 1
    assert out["wilcoxon_p"] == pytest.approx(2 / 2**9)
    assert out["rank_biserial"] == 1.0
    ref = sps.bootstrap((d,), np.mean, n_resamples=stats.BOOTSTRAP_RESAMPLES, method="BCa",
                        rng=np.random.default_rng(stats.SEED)).confidence_interval
    assert (out["difference"].low, out["difference"].high) == (pytest.approx(ref.low), pytest.approx(ref.high))
    assert out["difference"].low < 1.58 < out["difference"].high  # (R's t interval is [0.70, 2.46]: skewed data)


def test_paired_test_refuses_below_the_minimum_pairs():
    for n in (1, 2, stats.MIN_TEST_PAIRS - 1):
        out = stats.paired_test([0.1] * n, [0.2 + 0.01 * i for i in range(n)])
        assert out["ttest_p"] is None and out["wilcoxon_p"] is None and out["cohens_dz"] is None
        assert f"n = {n} < {stats.MIN_TEST_PAIRS}: no paired test" in out["reason"]
        assert out["difference"].value == pytest.approx(np.mean([0.1 + 0.01 * i for i in range(n)]))
        assert out["difference"].low is None
    with pytest.raises(ValueError, match="differ in length"):
        stats.paired_test([1, 2], [1])


def test_rank_biserial_by_hand():
    # |d| ranks: 0.1 -> 1, 0.2 -> 2, 0.3 -> 3, 0.4 -> 4; positives 1 + 3 + 4 = 8, negatives 2; (8 - 2) / 10
    assert stats.rank_biserial([0.1, -0.2, 0.3, 0.4, 0.0]) == pytest.approx(0.6)
    assert stats.rank_biserial([0.0, 0.0]) is None


def test_holm_matches_r_p_adjust():
    # R: p.adjust(c(0.01, 0.04, 0.03, 0.005), "holm") -> 0.03 0.06 0.06 0.02
    assert stats.holm([0.01, 0.04, 0.03, 0.005]) == pytest.approx([0.03, 0.06, 0.06, 0.02])
    assert stats.holm([0.5, None, 0.01]) == [pytest.approx(0.5), None, pytest.approx(0.02)]
    assert stats.holm([0.7]) == [0.7] and stats.holm([]) == []
    assert stats.holm([0.6, 0.7]) == [1.0, 1.0]  # capped at 1


def test_mmrv_by_hand():
    # every unit's worst violation is a swap with its neighbour, 0.1 apart in reality
    assert stats.mmrv([0.1, 0.2, 0.3, 0.4], [0.2, 0.1, 0.4, 0.3]) == pytest.approx(0.1)
    # a tie in simulation against an order in reality: unit 0 (0.9 vs 0.3) counts 0.6, its partner nothing;
    # units 1 and 2 are swapped (0.3 vs 0.6): 0.3 each -> (0.6 + 0.3 + 0.3) / 3
    assert stats.mmrv([0.5, 0.5, 0.1], [0.9, 0.3, 0.6]) == pytest.approx(0.4)
    assert stats.mmrv([1, 2, 3], [10, 20, 30]) == 0.0  # same order: no violation
    assert stats.mmrv([3, 2, 1], [0.1, 0.5, 0.9]) == pytest.approx((0.8 + 0.4 + 0.8) / 3)  # reversed
    with pytest.raises(ValueError):
        stats.mmrv([1], [1])


def test_predictivity_on_constructed_data():
    sim, real = [1, 2, 3, 4, 5], [2, 1, 4, 3, 5]
    out = stats.predictivity(sim, real)
    # Spearman by hand: rank differences (-1, 1, -1, 1, 0): 1 - 6 * 4 / (5 * 24) = 0.8; the values are ranks,
    # so Pearson's r is 0.8 too
    assert out["spearman"]["value"] == pytest.approx(0.8) and out["pearson"]["value"] == pytest.approx(0.8)
    z, se = math.atanh(0.8), 1 / math.sqrt(2)  # Fisher: se = 1 / sqrt(n - 3)
    assert out["pearson"]["low"] == pytest.approx(math.tanh(z - 1.959964 * se), abs=1e-6)
    assert out["pearson"]["high"] == pytest.approx(math.tanh(z + 1.959964 * se), abs=1e-6)
    se_bw = math.sqrt((1 + 0.8**2 / 2) / 2)  # Bonett-Wright
    assert out["spearman"]["low"] == pytest.approx(math.tanh(z - 1.959964 * se_bw), abs=1e-6)
    assert out["spearman"]["p"] == pytest.approx(0.1040880, abs=1e-6)  # t = r sqrt(3 / (1 - r^2)) = 2.3094, df 3
    assert out["mmrv"]["value"] == pytest.approx((1 + 1 + 1 + 1 + 0) / 5)
    assert out["mmrv"]["low"] is not None and out["mmrv"]["low"] <= out["mmrv"]["value"] <= out["mmrv"]["high"]
    perfect = stats.predictivity([0.1, 0.2, 0.3, 0.4, 0.5, 0.6], [0.15, 0.22, 0.5, 0.51, 0.7, 0.9])
    assert perfect["spearman"]["value"] == pytest.approx(1.0) and perfect["mmrv"]["value"] == 0.0
    assert perfect["spearman"]["low"] is None and "perfect correlation" in perfect["spearman"]["reason"]


def test_predictivity_refusals():
    two = stats.predictivity([0.1, 0.2], [0.3, 0.1])  # swapped, 0.2 apart in reality: MMRV 0.2
    assert two["spearman"]["value"] is None and "n = 2 < 3: no correlation" in two["spearman"]["reason"]
    assert two["mmrv"]["value"] == pytest.approx(0.2) and "no interval" in two["mmrv"]["reason"]
    four = stats.predictivity([0.1, 0.2, 0.3, 0.4], [0.1, 0.3, 0.2, 0.4])
    assert four["pearson"]["value"] is not None and four["pearson"]["p"] is None and four["pearson"]["low"] is None
    assert "n = 4 < 5: no interval or p-value" in four["pearson"]["reason"]
    flat = stats.predictivity([0.2] * 5, [0.1, 0.2, 0.3, 0.4, 0.5])
    assert flat["pearson"]["value"] is None and "same value" in flat["pearson"]["reason"]
    with pytest.raises(ValueError):
        stats.predictivity([1, 2], [1])
