"""Sweeps (benchbot.batch.sweep): parsing, plans with shared seeds, and the robustness numbers on constructed data:
means over environments, counts and pairings known by hand; intervals and tests those of benchbot.batch.stats
(checked against SciPy called directly), over environments and over episodes, refused below 5 values / 6 pairs;
Holm's adjustment over the levels."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchbot.batch import stats
from benchbot.batch.sweep import (
    Sweep, parse_sweep, plan_sweep, plot_robustness, robustness, robustness_from_run, write_robustness,
)
from benchbot.core.errors import UsageError


def test_parse_sweep():
    assert parse_sweep("noise=none,low,realistic,high") == Sweep("noise", ("none", "low", "realistic", "high"))
    assert parse_sweep(" variant = 1, 3 ,5") == Sweep("variant", ("1", "3", "5"))
    for bad, words in [("noise", "is not FACTOR=LEVEL"), ("speed=1,2", "factor 'speed' is not one of"),
                       ("noise=low", "at least 2"), ("noise=low,,high", "at least 2"),
                       ("noise=low,low", "gives level 'low' twice"), ("noise=low,loud", "'loud' is not a noise preset"),
                       ("", "is not FACTOR=LEVEL")]:
        with pytest.raises(UsageError) as e:
            parse_sweep(bad)
        assert words in e.value.message and "--sweep" in e.value.message
        assert "\n" not in e.value.message + e.value.hint


def plan(sweep, registry=None, envs=("miniroom:1",), robots=("carter",), repeat=2):
    return plan_sweep(sweep, robots=list(robots), envs=list(envs), noise="none", registry=registry, task="t",
                      repeat=repeat, seed=100, argv=["x"], cwd=".", options={}, timeout_s=None)


def test_every_level_reuses_the_seeds():
    specs, level_of = plan(Sweep("noise", ("none", "low", "high")))
    assert [s.index for s in specs] == list(range(6))
    assert [s.seed for s in specs] == [100, 101] * 3
    assert [s.noise for s in specs] == ["none", "none", "low", "low", "high", "high"]
    assert level_of == {"0": "none", "1": "none", "2": "low", "3": "low", "4": "high", "5": "high"}
    assert len({s.results for s in specs}) == 6 and specs[2].results == "results/002_miniroom_1_noise-low_r0.json"
    robots, _ = plan(Sweep("robot", ("a", "b")), repeat=1)
    assert [(s.robot, s.seed) for s in robots] == [("a", 100), ("b", 100)]


def test_variant_and_lighting_levels_pick_environments(registry):
    specs, level_of = plan(Sweep("variant", ("1", "3")), registry, envs=("miniroom", "house:2"), repeat=1)
    assert [s.env for s in specs] == ["miniroom:1", "house:1", "miniroom:3", "house:3"]
    specs, _ = plan(Sweep("lighting", ("night", "day")), registry, envs=("miniroom:1",), repeat=1)
    assert [s.env for s in specs] == ["miniroom:3", "miniroom:2"]
    with pytest.raises(UsageError, match="no variant lit 'dusk'"):
        plan(Sweep("lighting", ("night", "dusk")), registry)


def noise_rows(levels: dict[str, list[float]], robot: str = "r") -> list[dict]:
    """One row per value: level ``lv``'s i-th value is environment ``e<i>`` (one episode each, so the environment
    level and the episode level hold the same numbers), and levels pair by i."""
    return [{"level": lv, "score": v, "env": f"e{i}", "repeat": 0, "robot": robot, "noise": lv}
            for lv, values in levels.items() for i, v in enumerate(values)]


def test_levels_are_means_over_environments_with_the_report_s_interval():
    """A level's mean and interval are :func:`benchbot.batch.stats.cluster_mean_ci`'s (Student's t over the
    environments' means below 30 environments), with the episode level beside it."""
    from scipy.stats import t

    values = [0.41, 0.52, 0.38, 0.60, 0.47, 0.55]
    s = robustness(noise_rows({"none": values, "low": [v - 0.1 for v in values]}), "noise", ["none", "low"],
                   score="OMQ")
    none = s["levels"][0]
    env = stats.cluster_mean_ci(values, [f"e{i}" for i in range(6)]).to_json()
    env["level_of_n"] = env.pop("level")
    assert none == {"level": "none", **env, "episodes": stats.mean_ci(values, level="episodes").to_json()}
    low, high = t.interval(0.95, 5, loc=np.mean(values), scale=np.std(values, ddof=1) / np.sqrt(6))
    assert (none["n"], none["value"], none["level_of_n"]) == (6, pytest.approx(sum(values) / 6), "environments")
    assert (none["low"], none["high"]) == (pytest.approx(low, abs=1e-12), pytest.approx(high, abs=1e-12))
    assert none["reason"] == "" and none["method"] == "Student t (n < 30)"
    assert s["policy"] == {**s["policy"], "confidence": stats.CONFIDENCE, "min_ci_n": stats.MIN_CI_N,
                           "min_test_pairs": stats.MIN_TEST_PAIRS, "seed": stats.SEED, "unit": "environment",
                           "bootstrap_resamples": stats.BOOTSTRAP_RESAMPLES}


def test_no_interval_below_5_environments_and_none_needed_without_spread():
    assert stats.MIN_CI_N == 5
    s = robustness(noise_rows({"a": [], "b": [0.5], "c": [0.5, 0.7, 0.6, 0.8], "d": [0.5, 0.7, 0.6, 0.8, 0.4],
                               "e": [0.3] * 5}), "variant", list("abcde"))
    a, b, c, d, e = s["levels"]
    assert (a["n"], a["value"], a["low"], a["reason"]) == (0, None, None, "no values")
    for lv in (b, c):
        assert lv["low"] is None and lv["high"] is None
        assert f"n = {lv['n']} < 5: no confidence interval over environments" == lv["reason"]
    assert c["value"] == pytest.approx(0.65)
    assert d["low"] is not None and d["low"] < 0.6 < d["high"] and d["reason"] == ""
    assert (e["low"], e["high"]) == (0.3, 0.3) and "every value is equal" in e["reason"]


def test_one_environment_has_no_interval_over_environments_but_its_episodes_have_one():
    values = [0.41, 0.52, 0.38, 0.60, 0.47, 0.55]
    r = [{"level": "none", "score": v, "env": "miniroom:1", "repeat": i, "robot": "r", "noise": "none"}
         for i, v in enumerate(values)]
    [lv] = robustness(r, "noise", ["none"])["levels"]
    assert (lv["n"], lv["low"]) == (1, None) and lv["episodes"]["n"] == 6 and lv["episodes"]["low"] is not None


def test_differences_are_the_report_s_paired_test_over_environments():
    """Each level against the baseline is :func:`benchbot.batch.stats.cluster_paired_test` over the environments
    (and :func:`~benchbot.batch.stats.paired_test` over the episode pairs): below 6 only the mean difference, with
    the reason; from 6 the interval, d_z, rank-biserial r and both p-values, which match SciPy called directly."""
    from scipy.stats import ttest_rel, wilcoxon

    base = [0.8, 0.7, 0.6, 0.5, 0.75, 0.65]
    drop = [0.10, 0.12, 0.08, 0.20, 0.05, 0.11]
    low = [b - d for b, d in zip(base, drop)]
    s = robustness(noise_rows({"none": base, "low": low, "high": [b - 0.3 for b in base[:5]]}), "noise",
                   ["none", "low", "high"])
    d_low, d_high = s["differences"]
    ref = stats.paired_test(base, low, level="environment pairs")
    assert d_low["difference"] == ref["difference"].to_json() and d_low["level_of_n"] == "environment pairs"
    assert (d_low["level"], d_low["baseline"], d_low["n"], d_low["unpaired"], d_low["reason"]) == (
        "low", "none", 6, 0, "")
    d = np.asarray(low) - np.asarray(base)
    assert d_low["difference"]["value"] == pytest.approx(-np.mean(drop))
    assert d_low["difference"]["low"] < d_low["difference"]["value"] < d_low["difference"]["high"] < 0
    assert d_low["cohens_dz"] == pytest.approx(d.mean() / d.std(ddof=1))
    assert d_low["rank_biserial"] == -1.0  # every difference negative
    assert d_low["ttest_p"] == pytest.approx(ttest_rel(low, base).pvalue)
    assert d_low["wilcoxon_p"] == pytest.approx(wilcoxon(low, base).pvalue) == pytest.approx(2 / 2 ** 6)
    assert d_low["episodes"]["n"] == 6 and d_low["episodes"]["ttest_p"] == pytest.approx(d_low["ttest_p"])
    # 5 environments (high has one episode fewer): no test, no interval, the reason; the mean difference still given
    assert (d_high["n"], d_high["unpaired"]) == (5, 1)
    assert d_high["difference"]["value"] == pytest.approx(-0.3) and d_high["difference"]["low"] is None
    assert d_high["reason"] == "n = 5 < 6: no paired test over environments" == d_high["difference"]["reason"]
    assert d_high["ttest_p"] is d_high["wilcoxon_p"] is d_high["cohens_dz"] is d_high["ttest_p_holm"] is None
    # one test in the family: Holm leaves its p-values as they are
    assert (d_low["ttest_p_holm"], d_low["wilcoxon_p_holm"]) == (d_low["ttest_p"], d_low["wilcoxon_p"])


def test_holm_across_the_levels(monkeypatch):
    """The p-values are Holm-adjusted over the levels compared with the baseline; a level without a test is not
    counted. Constructed p-values 0.01, 0.04, 0.03 (and none): ×3, ×2, ×1 in ascending order, kept monotone →
    0.03, 0.06, 0.06."""
    raw = iter([0.01, 0.01, 0.04, 0.04, 0.03, 0.03, None, None])  # each level: over environments, over episodes

    def fake(a, b, level="pairs"):
        p = next(raw)
        return {"n": len(a), "level": level, "difference": stats.Estimate(len(a), 0.0), "cohens_dz": None,
                "rank_biserial": None, "ttest_p": p, "wilcoxon_p": None if p is None else p / 2,
                "reason": "" if p else "refused"}

    monkeypatch.setattr(stats, "paired_test", fake)
    s = robustness(noise_rows({lv: [0.5] * 6 for lv in ("none", "a", "b", "c", "d")}), "noise",
                   ["none", "a", "b", "c", "d"])
    assert [d["ttest_p"] for d in s["differences"]] == [0.01, 0.04, 0.03, None]
    assert [d["ttest_p_holm"] for d in s["differences"]] == pytest.approx([0.03, 0.06, 0.06, None])
    assert [d["wilcoxon_p_holm"] for d in s["differences"]] == pytest.approx([0.015, 0.03, 0.03, None])
    assert [d["episodes"]["ttest_p_holm"] for d in s["differences"]] == pytest.approx([0.03, 0.06, 0.06, None])


def rows():
    """Three levels, 2 environments × 2 repetitions each; ``low`` is ``none`` − 0.1, 0.1, 0.1, 0.2 pair by pair;
    ``high`` has one episode missing."""
    base = {("a", 0): 0.8, ("a", 1): 0.7, ("b", 0): 0.6, ("b", 1): 0.5}
    drop = {("a", 0): 0.1, ("a", 1): 0.1, ("b", 0): 0.1, ("b", 1): 0.2}
    out = []
    for (env, rep), v in base.items():
        out.append({"level": "none", "score": v, "env": env, "repeat": rep, "robot": "r", "noise": "none"})
        out.append({"level": "low", "score": v - drop[(env, rep)], "env": env, "repeat": rep, "robot": "r",
                    "noise": "low"})
        if (env, rep) != ("b", 1):
            out.append({"level": "high", "score": v - 0.3, "env": env, "repeat": rep, "robot": "r", "noise": "high"})
    out.append({"level": "high", "score": float("nan"), "env": "b", "repeat": 1, "robot": "r", "noise": "high"})
    return out


def test_robustness_by_hand():
    s = robustness(rows(), "noise", ["none", "low", "high"])
    none, low, high = s["levels"]
    assert [lv["level"] for lv in s["levels"]] == ["none", "low", "high"]
    assert (none["n"], low["n"], high["n"]) == (2, 2, 2)  # environments
    assert [lv["episodes"]["n"] for lv in s["levels"]] == [4, 4, 3]  # the NaN score is left out
    assert none["value"] == pytest.approx(0.65) and low["value"] == pytest.approx((0.65 + 0.4) / 2)
    assert high["value"] == pytest.approx(((0.5 + 0.4) / 2 + 0.3) / 2)  # a: 0.5, 0.4; b: 0.3
    assert high["episodes"]["value"] == pytest.approx((0.5 + 0.4 + 0.3) / 3)
    assert all(lv["low"] is None and "< 5" in lv["reason"] for lv in s["levels"])
    d_low, d_high = s["differences"]
    # low − none per environment: a −0.1, b −0.15 → −0.125; 2 environments: no test
    assert (d_low["level"], d_low["baseline"], d_low["n"], d_low["unpaired"]) == ("low", "none", 2, 0)
    assert d_low["difference"]["value"] == pytest.approx(-0.125)
    assert d_low["reason"] == "n = 2 < 6: no paired test over environments"
    assert d_low["episodes"]["reason"] == "n = 4 < 6: no paired test"
    # high − none: −0.3 on the 3 pairs that exist, the baseline's fourth episode unpaired
    assert (d_high["n"], d_high["episodes"]["n"], d_high["unpaired"]) == (2, 3, 1)
    assert d_high["difference"]["value"] == pytest.approx(-0.3)
    assert d_high["ttest_p"] is None and d_high["ttest_p_holm"] is None


def test_environment_factors_have_no_pairs():
    r = [{"level": lv, "score": 0.5 + i / 10, "env": f"m:{lv}", "repeat": i, "robot": "r", "noise": "none"}
         for lv in ("1", "2") for i in range(3)]
    s = robustness(r, "variant", ["1", "2"])
    assert s["differences"] == [] and [lv["episodes"]["n"] for lv in s["levels"]] == [3, 3]


def test_plot_and_run_directory(tmp_path):
    from benchbot.batch.plan import new_record, plan_episodes, to_json, write_manifest

    specs, level_of = plan(Sweep("noise", ("none", "low")), repeat=6)
    write_manifest(tmp_path, {"task": "t", "environments": ["miniroom:1"], "plan": to_json(specs),
                              "episodes": to_json([new_record(s) for s in specs]),
                              "sweep": {"factor": "noise", "levels": ["none", "low"], "level_of": level_of}})
    with pytest.raises(UsageError, match="no episode_scores.json"):
        robustness_from_run(tmp_path)
    none, low = [0.5, 0.6, 0.7, 0.55, 0.65, 0.6], [0.4, 0.5, 0.5, 0.45, 0.5, 0.55]
    (tmp_path / "episode_scores.json").write_text(json.dumps([
        {"index": s.index, "env": s.env, "robot": s.robot, "repeat": s.repeat, "seed": s.seed, "noise": s.noise,
         "scores": {"OMQ": v}} for s, v in zip(specs, none + low)]))
    summary = write_robustness(tmp_path)
    assert summary["plots"] == ["robustness.png", "robustness.svg"]
    assert (tmp_path / "robustness.png").stat().st_size > 1000 and (tmp_path / "robustness.svg").is_file()
    saved = json.loads((tmp_path / "robustness.json").read_text())
    assert saved == json.loads(json.dumps(summary))
    assert saved["score"] == "OMQ"  # the method's primary score (here seen in the scores: no declaration)
    assert [lv["value"] for lv in saved["levels"]] == pytest.approx([0.6, 29 / 60])
    # one environment: no interval over environments; its episodes' interval is there, about miniroom:1 alone
    assert [(lv["n"], lv["low"], lv["episodes"]["low"] is not None) for lv in saved["levels"]] == [(1, None, True)] * 2
    assert saved["levels"][0]["episodes"] == stats.mean_ci(none, level="episodes").to_json()
    diff = saved["differences"][0]
    assert (diff["n"], diff["episodes"]["n"]) == (1, 6) and diff["difference"]["value"] == pytest.approx(-0.7 / 6)
    assert diff["episodes"]["ttest_p"] == pytest.approx(stats.paired_test(none, low)["ttest_p"])
    assert diff["episodes"]["ttest_p"] == diff["episodes"]["ttest_p_holm"]
    assert plot_robustness(summary, tmp_path / "again")[0].name == "again.png"
    # levels without an interval (n < 5) and one without episodes plot too
    few = robustness(rows(), "noise", ["none", "low", "high", "absent"])
    assert [p.name for p in plot_robustness(few, tmp_path / "few", rows())] == ["few.png", "few.svg"]
    not_a_sweep = tmp_path / "plain"
    not_a_sweep.mkdir()
    plain = plan_episodes(task="t", robots=["r"], envs=["miniroom:1"], repeat=1, seed=0, argv=["x"], cwd=".",
                          options={}, timeout_s=None)
    write_manifest(not_a_sweep, {"task": "t", "environments": ["miniroom:1"], "plan": to_json(plain),
                                 "episodes": to_json([new_record(s) for s in plain])})
    with pytest.raises(UsageError, match="is not a sweep"):
        robustness_from_run(not_a_sweep)


def test_printout_rounds_and_gives_the_reasons(tmp_path, capsys):
    """``benchbot batch --sweep`` prints 4 significant digits, both levels, and the reason where there is no
    interval or test."""
    from benchbot.cli.batch_cmd import print_robustness

    base = [0.8123456, 0.7, 0.6, 0.5, 0.75, 0.65]
    levels = {"none": base, "low": [b - d for b, d in zip(base, [0.10, 0.12, 0.08, 0.20, 0.05, 0.11])],
              "high": [0.5, 0.4, 0.3]}
    summary = robustness(noise_rows(levels), "noise", list(levels), score="OMQ")
    print_robustness(summary, tmp_path)
    text = capsys.readouterr().out
    assert "0.6687" in text and "0.66872" not in text  # the baseline's mean 4.0123456 / 6, 4 significant digits
    assert "n = 3 < 5: no confidence interval over environments" in text
    lo, hi = summary["levels"][0]["low"], summary["levels"][0]["high"]
    assert f"[{lo:.4g}, {hi:.4g}]" in text
    # high − none on the first 3 pairs: −0.3123456, −0.3, −0.3 → −0.3041152
    assert ("high − none (OMQ, 3 episodes unpaired): over 3 environments: mean difference -0.3041; n = 3 < 6: no "
            "paired test over environments | over 3 episode pairs (these environments only): mean difference "
            "-0.3041; n = 3 < 6: no paired test") in text
    d = summary["differences"][0]
    assert f"paired t-test p = {d['ttest_p']:.4g} (Holm {d['ttest_p_holm']:.4g})" in text
    assert "Cohen's d_z = " in text and "rank-biserial r = -1" in text


@pytest.mark.parametrize("sweep, field", [({"factor": "noise", "levels": ["none"]}, "$.sweep"),
                                          ({"factor": "noise", "levels": 3, "level_of": {}}, "$.sweep.levels")])
def test_an_edited_sweep_entry_is_a_one_line_error(tmp_path, sweep, field):
    from benchbot.batch.plan import new_record, to_json, write_manifest

    specs, _ = plan(Sweep("noise", ("none", "low")), repeat=1)
    write_manifest(tmp_path, {"task": "t", "environments": ["miniroom:1"], "plan": to_json(specs),
                              "episodes": to_json([new_record(s) for s in specs]), "sweep": sweep})
    with pytest.raises(UsageError) as e:
        robustness_from_run(tmp_path)
    assert f"manifest.json: {field}: " in e.value.message
