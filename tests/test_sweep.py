"""Sweeps (benchbot.batch.sweep): parsing, plans with shared seeds, and the robustness numbers on constructed data
whose answers are known by hand."""

from __future__ import annotations

import json
import math

import pytest

from benchbot.batch.sweep import (
    MIN_N, Sweep, mean_interval, parse_sweep, plan_sweep, plot_robustness, robustness, robustness_from_run,
    write_robustness,
)
from benchbot.core.errors import UsageError

#: t quantiles (0.975) by degrees of freedom, from tables (e.g. NIST/SEMATECH e-Handbook, table 1.3.6.7.2)
T975 = {2: 4.302653, 3: 3.182446, 4: 2.776445}


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


def test_mean_interval_by_hand():
    # 1, 2, 3: mean 2, sd 1, half-width t(0.975, 2) / √3
    r = mean_interval([1.0, 2.0, 3.0])
    assert (r["n"], r["mean"], r["sd"]) == (3, 2.0, 1.0)
    assert r["low"] == pytest.approx(2 - T975[2] / math.sqrt(3), abs=1e-6)
    assert r["high"] == pytest.approx(2 + T975[2] / math.sqrt(3), abs=1e-6)
    # 0.2, 0.4, 0.4, 0.6, 0.4: mean 0.4, sd √0.02, half-width t(0.975, 4) · √0.02 / √5
    r = mean_interval([0.2, 0.4, 0.4, 0.6, 0.4])
    assert r["mean"] == pytest.approx(0.4) and r["sd"] == pytest.approx(math.sqrt(0.02))
    assert r["high"] - r["mean"] == pytest.approx(T975[4] * math.sqrt(0.02 / 5), abs=1e-6)


def test_no_interval_below_the_minimum_n_and_none_needed_without_spread():
    assert MIN_N == 3
    for values in ([], [0.5], [0.5, 0.7]):
        r = mean_interval(values)
        assert r["low"] is None and r["high"] is None and f"< {MIN_N}" in r["note"] and "--repeat" in r["note"]
    assert mean_interval([0.5, 0.7])["mean"] == pytest.approx(0.6)
    r = mean_interval([0.3] * 4)
    assert (r["low"], r["high"], r["sd"]) == (0.3, 0.3, 0.0) and "all 4 values equal" in r["note"]


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
    return out


def test_robustness_by_hand():
    s = robustness(rows(), "noise", ["none", "low", "high"])
    none, low, high = s["levels"]
    assert [lv["level"] for lv in s["levels"]] == ["none", "low", "high"]
    assert (none["n"], low["n"], high["n"]) == (4, 4, 3)
    assert none["mean"] == pytest.approx(0.65) and low["mean"] == pytest.approx(0.525)
    assert high["mean"] == pytest.approx((0.5 + 0.4 + 0.3) / 3)
    # none: 0.8, 0.7, 0.6, 0.5 → sd √(0.05/3); half-width t(0.975, 3) · sd / 2
    assert none["high"] - none["mean"] == pytest.approx(T975[3] * math.sqrt(0.05 / 3) / 2, abs=1e-6)
    d_low, d_high = s["differences"]
    # low − none pair by pair: −0.1, −0.1, −0.1, −0.2 → mean −0.125, sd 0.05
    assert (d_low["level"], d_low["baseline"], d_low["pairs"]) == ("low", "none", 4)
    assert d_low["mean"] == pytest.approx(-0.125) and d_low["sd"] == pytest.approx(0.05)
    assert d_low["high"] == pytest.approx(-0.125 + T975[3] * 0.05 / 2, abs=1e-6)
    # t = −0.125 / (0.05 / 2) = −5 with 3 degrees of freedom: two-sided p = 0.015392
    assert d_low["p_value"] == pytest.approx(0.015392, abs=1e-5)
    # high − none: −0.3 on the 3 pairs that exist: no spread, so no p-value
    assert d_high["pairs"] == 3 and d_high["mean"] == pytest.approx(-0.3) and d_high["p_value"] is None
    assert "all 3 values equal" in d_high["note"]


def test_environment_factors_have_no_pairs():
    r = [{"level": lv, "score": 0.5 + i / 10, "env": f"m:{lv}", "repeat": i, "robot": "r", "noise": "none"}
         for lv in ("1", "2") for i in range(3)]
    s = robustness(r, "variant", ["1", "2"])
    assert s["differences"] == [] and [lv["n"] for lv in s["levels"]] == [3, 3]


def test_plot_and_run_directory(tmp_path):
    from benchbot.batch.plan import new_record, plan_episodes, to_json, write_manifest

    specs, level_of = plan(Sweep("noise", ("none", "low")), repeat=3)
    write_manifest(tmp_path, {"task": "t", "environments": ["miniroom:1"], "plan": to_json(specs),
                              "episodes": to_json([new_record(s) for s in specs]),
                              "sweep": {"factor": "noise", "levels": ["none", "low"], "level_of": level_of}})
    with pytest.raises(UsageError, match="no episode_scores.json"):
        robustness_from_run(tmp_path)
    scores = [0.5, 0.6, 0.7, 0.4, 0.5, 0.5]
    (tmp_path / "episode_scores.json").write_text(json.dumps([
        {"index": s.index, "env": s.env, "robot": s.robot, "repeat": s.repeat, "seed": s.seed, "noise": s.noise,
         "scores": {"OMQ": v}} for s, v in zip(specs, scores)]))
    summary = write_robustness(tmp_path)
    assert summary["plots"] == ["robustness.png", "robustness.svg"]
    assert (tmp_path / "robustness.png").stat().st_size > 1000 and (tmp_path / "robustness.svg").is_file()
    saved = json.loads((tmp_path / "robustness.json").read_text())
    assert [lv["mean"] for lv in saved["levels"]] == pytest.approx([0.6, 14 / 30])
    assert saved["differences"][0]["mean"] == pytest.approx(-0.4 / 3)
    assert plot_robustness(summary, tmp_path / "again")[0].name == "again.png"
    not_a_sweep = tmp_path / "plain"
    not_a_sweep.mkdir()
    plain = plan_episodes(task="t", robots=["r"], envs=["miniroom:1"], repeat=1, seed=0, argv=["x"], cwd=".",
                          options={}, timeout_s=None)
    write_manifest(not_a_sweep, {"task": "t", "environments": ["miniroom:1"], "plan": to_json(plain),
                                 "episodes": to_json([new_record(s) for s in plain])})
    with pytest.raises(UsageError, match="is not a sweep"):
        robustness_from_run(not_a_sweep)
