"""benchbot report: statistics that refuse what n cannot support, pairing by environment and seed, Holm over
comparisons, per-class tables and top-down maps from re-scored results, paper files (PNG/SVG/PDF, CSV/LaTeX), run
labels and provenance, lighting's confounding, rounded CLI numbers and one-line errors."""

from __future__ import annotations

import csv
import json
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from scipy import stats as sps

from benchbot.batch import stats
from benchbot.batch.analysis import analyse, factor_views
from benchbot.batch.object_views import driven_path, per_class_rows
from benchbot.batch.report import write_report
from benchbot.batch.run_data import UnfinishedRun, assign_labels, default_label, load_run
from benchbot.batch.run_stats import compare, comparisons, pair_episodes
from benchbot.core.errors import UsageError
from benchbot.core.registry import get_registry

sys.path.insert(0, str(Path(__file__).parent))
import report_runs  # noqa: E402
from report_runs import make_run, scores_only_run  # noqa: E402

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]
NUMBER = re.compile(r"\d+\.\d+")


def too_precise(text: str) -> list[str]:
    """Decimal numbers in ``text`` with more than 4 significant digits (a float printed with all its digits)."""
    return [m for m in NUMBER.findall(text) if len(m.replace(".", "").lstrip("0")) > 4]


def cli(*args):
    return subprocess.run([*BENCHBOT, *args], capture_output=True, text=True, timeout=300)


def test_too_few_episodes_get_no_interval_and_say_why(tmp_path):
    run = load_run(scores_only_run(tmp_path, "a", {"miniroom:1": [0.1601], "miniroom:2": [0.2, 0.3],
                                                   "house:1": [0.1, 0.2, 0.3, 0.4, 0.5, 0.35]}))
    result = analyse([run])
    envs = result["runs"][0]["environments"]
    assert envs["miniroom:1"]["low"] is None and envs["miniroom:1"]["reason"] == "n = 1 < 5: no confidence interval"
    assert envs["miniroom:2"]["low"] is None and envs["miniroom:2"]["n"] == 2
    assert envs["house:1"]["low"] < envs["house:1"]["value"] < envs["house:1"]["high"]
    # the environment is the unit: 3 environments, no interval; the episode level (9 episodes) has one
    summary, episodes = result["runs"][0]["summary"]["OMQ"], result["runs"][0]["summary_episodes"]["OMQ"]
    assert (summary["n"], summary["level"], summary["low"]) == (3, "environments", None)
    assert summary["reason"] == "n = 3 < 5: no confidence interval over environments"
    assert summary["value"] == pytest.approx((0.1601 + 0.25 + 0.3083333333) / 3)
    assert (episodes["n"], episodes["level"]) == (9, "episodes") and episodes["low"] is not None
    assert result["policy"]["min_ci_n"] == stats.MIN_CI_N == 5 and result["policy"]["unit"] == "environment"
    assert result["main_score"] == "OMQ" and result["scores"]["scores"][0]["name"] == "OMQ"


def test_environment_means_are_the_unit_of_intervals_and_tests(tmp_path):
    """Nested data (rooms differ far more than repetitions in a room): the interval over environments is wider
    than the episodes' and the test over environments has a larger p-value than over pseudo-replicated episodes."""
    rng = np.random.default_rng(7)
    envs = [f"miniroom:{v}" for v in range(1, 6)] + [f"house:{v}" for v in range(1, 4)]
    room = dict(zip(envs, rng.uniform(0.1, 0.6, len(envs))))
    base = {e: list(room[e] + rng.normal(0, 0.01, 3)) for e in envs}
    shift = dict(zip(envs, rng.normal(0.02, 0.03, len(envs))))
    other = {e: [v + shift[e] + rng.normal(0, 0.005) for v in vs] for e, vs in base.items()}
    a, b = load_run(scores_only_run(tmp_path, "a", base)), load_run(scores_only_run(tmp_path, "b", other))
    summary = analyse([a])["runs"][0]
    env, ep = summary["summary"]["OMQ"], summary["summary_episodes"]["OMQ"]
    assert (env["n"], ep["n"]) == (8, 24) and env["high"] - env["low"] > 1.5 * (ep["high"] - ep["low"])
    means = [np.mean(v) for v in base.values()]
    assert (env["low"], env["high"]) == (pytest.approx(sps.t.interval(0.95, 7, np.mean(means), sps.sem(means))[0]),
                                         pytest.approx(sps.t.interval(0.95, 7, np.mean(means), sps.sem(means))[1]))
    c = compare(a, b, "OMQ")
    assert (c["n"], c["level"], c["episodes"]["n"]) == (8, "environment pairs", 24)
    diffs = [np.mean(np.subtract(other[e], base[e])) for e in envs]
    assert c["environment_differences"] == pytest.approx(diffs)
    assert c["ttest_p"] == pytest.approx(sps.ttest_1samp(diffs, 0).pvalue)
    assert c["episodes"]["ttest_p"] < c["ttest_p"]  # pseudo-replication: too small a p-value


def test_pairs_by_environment_and_seed_else_by_repetition(tmp_path):
    a = load_run(scores_only_run(tmp_path, "a", {"miniroom:1": [0.2, 0.3], "house:1": [0.25], "house:9": [0.9]}))
    b = load_run(scores_only_run(tmp_path, "b", {"miniroom:1": [0.4, 0.5], "house:1": [0.5]}))
    pairs = pair_episodes(a, b, "OMQ")
    assert pairs["pairing"] == "environment and seed" and pairs["factors"] == []
    assert pairs["keys"] == ["miniroom:1 s0", "miniroom:1 s1", "house:1 s2"]
    assert (pairs["a"], pairs["b"], pairs["unpaired"]) == ([0.2, 0.3, 0.25], [0.4, 0.5, 0.5], 1)
    shifted = load_run(scores_only_run(tmp_path, "c", {"miniroom:1": [0.4, 0.5], "house:1": [0.5]}, seed=100))
    pairs = pair_episodes(a, shifted, "OMQ")
    assert pairs["pairing"] == "environment and repetition (the seeds differ)" and len(pairs["a"]) == 3
    c = compare(a, b, "OMQ")
    assert c["n"] == 2 and c["ttest_p"] is None and c["reason"] == "n = 2 < 6: no paired test over environments"
    assert c["difference"]["value"] == pytest.approx(((0.2 + 0.2) / 2 + 0.25) / 2)  # the environments' mean
    assert c["episodes"]["n"] == 3 and c["episodes"]["reason"] == "n = 3 < 6: no paired test"
    assert c["episodes"]["difference"]["value"] == pytest.approx((0.2 + 0.2 + 0.25) / 3)


def test_runs_with_different_repeats_pair_every_environment_and_say_what_was_left_out(tmp_path, capsys):
    """--repeat 2 against --repeat 1 on six environments: seeds are numbered across a batch, so by
    environment and seed only miniroom:1's first episode pairs. The environment level pairs the six environments'
    means (every episode counts), the episode level pairs by repetition, and the CLI says in one line what it left
    out and why."""
    from benchbot.cli.report_cmd import _print_report

    rng = np.random.default_rng(3)
    envs = [f"miniroom:{v}" for v in range(1, 4)] + [f"house:{v}" for v in range(1, 4)]
    room = dict(zip(envs, rng.uniform(0.2, 0.6, 6)))
    twice = {e: list(room[e] + rng.normal(0, 0.01, 2)) for e in envs}
    once = {e: [room[e] + 0.02 + rng.normal(0, 0.01)] for e in envs}
    a, b = load_run(scores_only_run(tmp_path, "r2", twice)), load_run(scores_only_run(tmp_path, "r1", once))
    assign_labels([a, b], ["geomR", "geomN"])
    seeds = {r["env"]: r["seed"] for r in b.rows}
    assert sum(r["seed"] == seeds[r["env"]] for r in a.rows) == 1  # by seed, one pair of 18 episodes
    c = compare(a, b, "OMQ")
    diffs = [once[e][0] - np.mean(twice[e]) for e in envs]
    assert (c["n"], c["environments"]) == (6, envs)
    assert c["environment_differences"] == pytest.approx(diffs)
    assert c["difference"]["value"] == pytest.approx(np.mean(diffs))
    assert c["ttest_p"] == pytest.approx(sps.ttest_1samp(diffs, 0).pvalue)
    assert c["wilcoxon_p"] == pytest.approx(sps.wilcoxon(diffs).pvalue)
    assert c["episodes"]["n"] == 6 and c["pairing"] == "environment and repetition (the seeds differ)"
    assert c["unpaired"] == 6 and c["unpaired_environments"] == []
    assert c["left_out"] == ("at the episode level 6 of 18 episodes (geomR ran 2 episodes per environment, geomN 1 "
                             "episode per environment); the environment level uses every episode")
    _print_report(analyse([a, b]))
    printed = capsys.readouterr().out
    assert "\n  left out: at the episode level 6 of 18 episodes" in printed
    assert "  IQM OMQ over environments " in printed and "  P(geomN better than geomR in an episode" in printed
    # an environment only one run has is left out of both levels, by name
    extra = load_run(scores_only_run(tmp_path, "r1x", {**once, "house:5": [0.5]}))
    c = compare(a, extra, "OMQ")
    assert c["n"] == 6 and c["unpaired_environments"] == ["house:5"]
    assert c["left_out"].startswith("1 environment only r1x ran (house:5): no partner; at the episode level 7 of 19")


@pytest.mark.parametrize("setting", ["noise", "robot"])
def test_runs_that_differ_in_noise_or_robot_pair_on_environment_and_seed(tmp_path, setting):
    """A run with noise preset high (or robot turtlebot4) against one with none (carter): the episodes pair on
    environment and seed, the differing setting is the factor compared, and the seeds are not said to differ."""
    envs = {f"miniroom:{v}": [0.3 + 0.02 * v, 0.32 + 0.02 * v] for v in range(1, 4)}
    a = load_run(scores_only_run(tmp_path, "a", envs))
    other = {"noise": {"noise": "high"}, "robot": {"robot": "turtlebot4"}}[setting]
    b = load_run(scores_only_run(tmp_path, "b", {e: [x - 0.05 for x in v] for e, v in envs.items()}, **other))
    c = compare(a, b, "OMQ")
    what, old, new = {"noise": ("noise preset", "none", "high"), "robot": ("robot", "carter", "turtlebot4")}[setting]
    assert c["factors"] == [{"field": setting, "what": what, "a": old, "b": new}]
    assert c["pairing"] == f"environment and seed; factor compared: {what} {old} → {new}"
    assert "seeds differ" not in c["pairing"] and c["episodes"]["n"] == 6 and c["unpaired"] == 0
    assert c["difference"]["value"] == pytest.approx(-0.05)
    result = analyse([a, b])
    assert result["differences"] == []  # the factor is named: no warning about it


def test_comparisons_have_effect_sizes_and_holm_adjusted_p_values(tmp_path):
    envs = [f"miniroom:{v}" for v in range(1, 6)] + ["house:1", "house:2"]  # 7 environments, 14 pairs
    base = {e: [0.20 + 0.01 * k, 0.22 + 0.01 * k] for k, e in enumerate(envs)}
    better = {e: [x + 0.05 + 0.004 * k + 0.001 * j for j, x in enumerate(v)] for k, (e, v) in enumerate(base.items())}
    same = {e: [x + (0.002 if j else -0.003) + 0.001 * (k % 3 - 1) for j, x in enumerate(v)]
            for k, (e, v) in enumerate(base.items())}
    runs = [load_run(scores_only_run(tmp_path, n, d)) for n, d in (("a", base), ("b", better), ("c", same))]
    assign_labels(runs, ["baseline", "better", "same"])
    out = comparisons(runs)
    assert [c["b"] for c in out] == ["better", "same"] and all(c["n"] == 7 and c["episodes"]["n"] == 14 for c in out)
    raw = [c["ttest_p"] for c in out]
    assert [c["ttest_p_holm"] for c in out] == pytest.approx(stats.holm(raw))
    assert [c["episodes"]["ttest_p_holm"] for c in out] == pytest.approx(stats.holm([c["episodes"]["ttest_p"] for c in out]))
    assert out[0]["ttest_p_holm"] == pytest.approx(min(1.0, 2 * min(raw)))  # the smaller p is doubled
    assert out[0]["cohens_dz"] > 1 and out[0]["rank_biserial"] == 1.0 and out[0]["ttest_p"] < 0.001
    assert out[0]["difference"]["low"] > 0 and out[0]["difference"]["method"] == "Student t (n < 30)"


def test_runs_that_differ_in_an_unnamed_condition_are_warned_about(tmp_path):
    a = load_run(scores_only_run(tmp_path, "a", {"miniroom:1": [0.2]}))
    furnished = dict(report_runs.BACKEND, style="furnished", version="0.2.0")
    b = load_run(scores_only_run(tmp_path, "b", {"miniroom:1": [0.3]}, backend=furnished))
    result = analyse([a, b])
    what = {d["what"]: d["values"] for d in result["differences"]}
    assert set(what) == {"simulator", "simulator style"}
    assert what["simulator style"] == {"a": "primitives", "b": "furnished"}
    assert what["simulator"] == {"a": "benchbot-sim-taichi 0.1.0", "b": "benchbot-sim-taichi 0.2.0"}
    assert analyse([a, b], factors=["simulator style", "simulator"])["differences"] == []
    with pytest.raises(UsageError, match="--factor: 'style' is not a condition"):
        analyse([a, b], factors=["style"])
    old = load_run(scores_only_run(tmp_path, "c", {"miniroom:1": [0.3]}, backend={}))  # recorded nothing
    assert analyse([a, old])["differences"] == []


def test_an_interrupted_batch_names_resume(tmp_path):
    run = scores_only_run(tmp_path, "a", {"miniroom:1": [0.2, 0.3]})
    manifest = json.loads((run / "manifest.json").read_text())
    manifest["episodes"][1]["status"] = "pending"
    (run / "manifest.json").write_text(json.dumps(manifest))
    (run / "episode_scores.json").unlink()
    with pytest.raises(UnfinishedRun) as e:
        load_run(run)
    assert "the batch did not finish (1 of 2 episodes not run)" in e.value.message
    assert e.value.hint == f"finish it: benchbot batch --resume {run}"
    manifest["episodes"][1]["status"] = "ok"
    manifest["finished"] = "2026-11-24T00:00:00+00:00"
    (run / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(UsageError, match="the batch was not evaluated") as e:
        load_run(run)
    assert not isinstance(e.value, UnfinishedRun) and "--evaluate-with" in e.value.hint



@pytest.mark.parametrize("entry, value, field", [("provenance", "x", "$.provenance"),
                                                 ("provenance", {"machine": "x"}, "$.provenance.machine"),
                                                 ("scores", {"scores": [{"name": "OMQ", "range": 5}]}, None)])
def test_a_malformed_manifest_entry_is_refused_in_one_line_or_ignored(tmp_path, entry, value, field):
    run = scores_only_run(tmp_path, "a", {"miniroom:1": [0.2, 0.3]}, manifest={entry: value})
    if field is None:  # a recorded declaration that does not read: the scores' own names stand in
        data = load_run(run)
        assert data.primary == "OMQ" and analyse([data])["runs"]
        return
    with pytest.raises(UsageError) as e:
        load_run(run)
    assert f"manifest.json: {field}: " in e.value.message and "\n" not in e.value.message

def test_labels_from_the_solution_not_the_timestamp(tmp_path):
    a = load_run(scores_only_run(tmp_path, "batch-20261122-103519", {"miniroom:1": [0.1]}))
    b = load_run(scores_only_run(tmp_path, "batch-20261122-104000", {"miniroom:1": [0.2]}, example="hello_active"))
    assert default_label(a.manifest, a.run_dir) == "semslam_geometric"
    assign_labels([a, b], None)
    assert (a.label, b.label) == ("semslam_geometric", "hello_active")
    c = load_run(scores_only_run(tmp_path, "batch-2", {"miniroom:1": [0.2]}))
    assign_labels([a, c], None)
    assert (a.label, c.label) == ("semslam_geometric (batch-20261122-103519)", "semslam_geometric (batch-2)")
    native = {"command": ["benchbot", "batch", "--native", "python -u my_slam.py --fast"]}
    assert default_label(native, Path("x")) == "my_slam.py"
    with pytest.raises(UsageError, match="--label: 1 labels for 2 run directories"):
        assign_labels([a, c], ["only one"])


def test_lighting_is_shown_only_within_an_environment(tmp_path):
    a = load_run(scores_only_run(tmp_path, "a", {"miniroom:1": [0.2], "miniroom:3": [0.1]}))
    run_config = json.loads((a.run_dir / "config.json").read_text())
    run_config["environments"]["miniroom:3"] = [{"lighting": "night"}]
    (a.run_dir / "config.json").write_text(json.dumps(run_config))
    a = load_run(a.run_dir)
    [view] = factor_views([a])
    assert view["factor"] == "lighting" and view["groups"] == []
    assert "would compare variants, not lighting" in view["note"] and "night: miniroom:3" in view["note"]
    day = make_run(tmp_path, "day", {"miniroom:1": [0.8]}, plan_options={"lighting": "day"})
    night = make_run(tmp_path, "night", {"miniroom:1": [0.6]}, plan_options={"lighting": "night"})
    [view] = factor_views([load_run(day), load_run(night)])
    assert view["groups"] == ["miniroom:1 day", "miniroom:1 night"]


def test_per_class_and_per_object_views_from_rescored_results(tmp_path):
    run = load_run(make_run(tmp_path, "a", {"miniroom:1": [0.9, 0.7], "miniroom:2": [0.8]}))
    result = analyse([run], get_registry())
    assert result["runs"][0]["objects_note"] == ""  # re-scored OMQ equals the run's
    rows = per_class_rows(run)
    gt = get_registry().ground_truth("miniroom:1")["ground_truth"]["objects"]
    gt2 = get_registry().ground_truth("miniroom:2")["ground_truth"]["objects"]
    assert list(rows[0]) == ["class", "TP", "FP", "FN", "OMQ", "avg_pairwise", "avg_label", "avg_spatial",
                             "avg_fp_quality"]  # the method's declared counts and scores, in its order
    assert sum(r["TP"] + r["FN"] for r in rows) == 2 * len(gt) + len(gt2)
    assert sum(r["FN"] for r in rows) == 2 * (len(gt) // 5) + len(gt2) // 5  # every fifth object is missed
    assert sum(r["FP"] for r in rows) == 3 * 2
    matches = run.objects[0]["matches"]
    assert len(matches["ground_truth"]) == len(gt) and {p["status"] for p in matches["proposals"]} <= {"TP", "FP", "group"}


def test_the_ground_truth_set_is_a_condition_and_rescoring_uses_the_runs_set(tmp_path):
    """The same maps scored against isaac_develop and bear_develop: the set is a condition (warned about,
    a leaderboard table of its own), and the per-class and per-object views re-score each run against the set it
    used, so they equal its scores and claim no change of the ground truth; a run that did not record its set is
    re-scored against the default and says so."""
    from benchbot.batch.leaderboard import entries
    from benchbot.core.evaluation import evaluate

    reg = get_registry()
    qualities = {"miniroom:1": [0.95], "miniroom:2": [0.9]}
    isaac = load_run(make_run(tmp_path, "isaac", qualities))
    bear = load_run(make_run(tmp_path, "bear", qualities, ground_truth_set="bear_develop"))
    assert {r["ground_truth_set"] for r in isaac.rows} == {"isaac_develop"}
    assert {r["ground_truth_set"] for r in bear.rows} == {"bear_develop"}
    assert isaac.rows[0]["OMQ"] != pytest.approx(bear.rows[0]["OMQ"])  # miniroom:1's two sets differ
    result = analyse([isaac, bear], reg)
    assert {d["what"]: d["values"] for d in result["differences"]}["ground truth"] == {
        "isaac": "isaac_develop", "bear": "bear_develop"}
    assert analyse([isaac, bear], factors=["ground truth"])["differences"] == []
    [tables_] = entries([isaac, bear]).values()
    assert sorted(dict(t["conditions"])["ground truth"] for t in tables_) == ["bear_develop", "isaac_develop"]
    assert [r["objects_note"] for r in result["runs"]] == ["", ""]
    for run in (isaac, bear):
        for row in run.rows:
            evaluation = run.objects[row["index"]]
            assert evaluation["scores"]["OMQ"] == pytest.approx(row["OMQ"], abs=1e-12)
            assert evaluation["ground_truth_set"] == row["ground_truth_set"]
    paths = [str(bear.run_dir / r["results"]) for r in bear.rows]
    against = {s: evaluate(paths, "omq", reg, options={"per_class": True}, ground_truth_set=s).combined["per_class"]
               for s in ("bear_develop", "isaac_develop")}
    assert bear.per_class == against["bear_develop"] != against["isaac_develop"]
    # a batch from before the set was recorded: re-scored against the default, and it says so
    old = bear.run_dir
    manifest = json.loads((old / "manifest.json").read_text())
    del manifest["ground_truth_set"], manifest["ground_truth_sets"]
    (old / "manifest.json").write_text(json.dumps(manifest))
    rows = json.loads((old / "episode_scores.json").read_text())
    (old / "episode_scores.json").write_text(json.dumps([{k: v for k, v in r.items() if k != "ground_truth_set"}
                                                         for r in rows]))
    unrecorded = load_run(old)
    assert {r["ground_truth_set"] for r in unrecorded.rows} == {""}
    note = analyse([unrecorded], reg)["runs"][0]["objects_note"]
    assert "the run did not record its set of ground truths, and was re-scored against isaac_develop" in note
    assert "changed since" not in note


@pytest.mark.slow
def test_report_files_for_papers(tmp_path, monkeypatch):
    """The whole report of two runs: every figure in three formats with no label over another and no warning
    printed, tables as CSV and LaTeX, maps with the driven path, labels instead of timestamps, provenance."""
    import warnings

    from benchbot.batch import figures

    a = load_run(make_run(tmp_path, "batch-20261122-100000", {"miniroom:1": [0.9, 0.85], "miniroom:2": [0.8]},
                          trajectories=True))
    b = load_run(make_run(tmp_path, "batch-20261122-110000", {"miniroom:1": [0.6, 0.65], "miniroom:2": [0.7]},
                          example="hello_active"))
    assign_labels([a, b], None)
    overlaps = {}
    render = figures.render

    def checked(fig):
        title = fig.get_suptitle() or fig.axes[0].get_title()
        overlaps[title] = figures.text_overlaps(fig) + figures.print_problems(fig)
        return render(fig)

    monkeypatch.setattr(figures, "render", checked)
    output = tmp_path / "out" / "report.html"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        write_report([a, b], output, get_registry())
    assert [str(w.message) for w in caught] == []  # nothing printed to the terminal
    assert len(overlaps) == 8 and {k: v for k, v in overlaps.items() if v} == {}
    page = output.read_text()
    files = output.parent / "report_files"
    for stem in ("summary", "environments", "comparison_1", "per_class_1", "per_class_2", "map_miniroom_1",
                 "map_miniroom_2", "score_distribution"):
        assert (files / f"{stem}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert (files / f"{stem}.pdf").read_bytes()[:5] == b"%PDF-"
        ET.fromstring((files / f"{stem}.svg").read_bytes())  # well-formed SVG
        assert f"report_files/{stem}.svg" in page and f"report_files/{stem}.pdf" in page
    with (files / "summary.csv").open() as f:
        rows = list(csv.reader(f))
    assert rows[0] == ["run", "environments", "episodes", "OMQ over environments", "OMQ over environments low",
                       "OMQ over environments high", "OMQ over environments n", "OMQ over episodes",
                       "OMQ over episodes low", "OMQ over episodes high", "OMQ over episodes n"]
    env_means = [(a.rows[0]["OMQ"] + a.rows[1]["OMQ"]) / 2, a.rows[2]["OMQ"]]
    assert rows[1][:3] == ["semslam_geometric", "2", "3"] and float(rows[1][3]) == pytest.approx(np.mean(env_means))
    assert rows[1][6] == "2" and rows[1][10] == "3"  # what each interval is over
    assert float(rows[1][7]) == pytest.approx(np.mean([r["OMQ"] for r in a.rows]))
    tex = (files / "per_class_1.tex").read_text()
    assert "\\begin{table" in tex and "\\toprule" in tex and "potted plant" in tex
    assert "\\label{tab:summary}" in (files / "summary.tex").read_text()
    # maps draw what the robot drove (the trajectory log, 0.25 m beside the plan), the plan faintly
    path, source = driven_path(a, a.rows[0])
    plan = get_registry().scenes("miniroom:1")[0]["trajectory_poses"]
    assert source == "trajectory log" and path[1:, 1] == pytest.approx([p[5] + 0.25 for p in plan])
    assert driven_path(b, b.rows[0]) == (None, "")
    assert "no driven path recorded" in (files / "map_miniroom_1.svg").read_text()  # b's panel says so
    # the page: labels instead of timestamps in the legends, n stated, provenance, statistics policy
    assert "semslam_geometric" in page and "hello_active" in page and "0123456789abcdef" in page
    assert "n = 2 &lt; 6: no paired test over environments" in page and "How to read the numbers" in page
    assert "the unit is the <b>environment</b>" in page.replace("The unit", "the unit")
    assert "Test CPU, 2 CPUs, 8 GiB" in page and "benchbot batch --example semslam_geometric" in page
    assert page.count("data:image/png;base64,") == 8
    assert json.loads((files / "report.json").read_text())["comparisons"][0]["episodes"]["n"] == 3
    assert too_precise(re.sub(r"data:image/png;base64,[^']*", "", page)) == []


@pytest.mark.slow
def test_cli_prints_rounded_numbers_and_refusals(tmp_path):
    a = scores_only_run(tmp_path, "a", {"miniroom:1": [0.16012345678], "miniroom:2": [0.3]})
    b = scores_only_run(tmp_path, "b", {"miniroom:1": [0.1578656], "miniroom:2": [0.3001]})
    proc = cli("report", str(a), str(b))
    assert proc.returncode == 0, proc.stderr
    assert "0.1601" in proc.stdout and "n = 1 < 5: no confidence interval" in proc.stdout
    said = proc.stderr.splitlines()  # into a log: a plain line per step before the numbers, never a silence
    assert said[:3] == ["reading run directory 1 of 2 …", "reading run directory 2 of 2 …", "analysing 2 runs …"]
    assert "\x1b[" not in proc.stderr
    assert "mean difference -0.001079" in proc.stdout  # (-0.002258 + 0.0001) / 2 and "n = 2 < 6: no paired test" in proc.stdout
    assert too_precise(proc.stdout) == [], proc.stdout
    proc = cli("report", str(a), str(b), "--plan-width", "0.05", "--plan-difference", "0.01")
    assert proc.returncode == 0 and "(a): n = 2 < 3: no plan (the SD of so few environments" in proc.stdout
    assert "(b) − semslam_geometric (a): n = 2 < 3: no plan" in proc.stdout
    proc = cli("report", str(a), "--plan-width", "-0.1")
    assert proc.returncode == 2 and "--plan-width: -0.1 is not a positive number" in proc.stderr
    proc = cli("report", str(a), str(b), "--json", "--label", "A", "--label", "B")
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    assert [r["label"] for r in result["runs"]] == ["A", "B"]
    assert result["comparisons"][0]["ttest_p"] is None
    # a condition the comparison does not name: a warning, or with --strict a refusal naming it and --factor
    c = scores_only_run(tmp_path, "c", {"miniroom:1": [0.2], "miniroom:2": [0.3]},
                        backend=dict(report_runs.BACKEND, style="furnished"))
    proc = cli("report", str(a), str(c))
    assert proc.returncode == 0 and "warning: the runs differ in simulator style" in proc.stderr
    assert "primitives" in proc.stderr and "furnished" in proc.stderr
    proc = cli("report", str(a), str(c), "--strict")
    assert proc.returncode == 2 and "the runs differ in simulator style" in proc.stderr
    assert "--factor 'simulator style'" in proc.stderr and "Traceback" not in proc.stderr
    proc = cli("report", str(a), str(c), "--strict", "--factor", "simulator style")
    assert proc.returncode == 0 and "warning" not in proc.stderr


@pytest.mark.slow
def test_report_errors_are_one_line(tmp_path):
    proc = cli("report", str(tmp_path))
    assert proc.returncode == 2 and "is not a batch run directory" in proc.stderr and "Traceback" not in proc.stderr
    run = scores_only_run(tmp_path, "a", {"miniroom:1": [0.1]})
    (run / "episode_scores.json").write_text(json.dumps([{"index": 0, "env": "miniroom:1"}]))
    proc = cli("report", str(run))
    assert proc.returncode == 2 and "episode_scores.json: malformed ([0].robot)" in proc.stderr
    said = [line for line in proc.stderr.strip().splitlines() if not line.startswith("reading run directory")]
    assert "Traceback" not in proc.stderr and len(said) == 2  # error + hint (after the progress line)
    (run / "episode_scores.json").write_text("[1, 2")
    proc = cli("report", str(run))
    assert proc.returncode == 2 and "episode_scores.json is unreadable or not JSON" in proc.stderr
    good = scores_only_run(tmp_path, "b", {"miniroom:1": [0.1]})
    proc = cli("report", str(good), "--label", "x", "--label", "y")
    assert proc.returncode == 2 and "--label: 2 labels for 1 run directories" in proc.stderr
    (tmp_path / "a_file").write_text("")
    proc = cli("report", str(good), "-o", str(tmp_path / "a_file" / "report.html"))
    assert proc.returncode == 2 and "--output: cannot write" in proc.stderr and "Traceback" not in proc.stderr


@pytest.mark.slow
def test_maps_read_the_driven_path_from_a_recording(tmp_path):
    """A run without trajectory logs but with `--record` recordings: the map's path is the recording's /tf map →
    robot positions, which end where the plan does (the passive robot follows it)."""
    import shutil

    from benchbot.api import ActionResult, BenchBot
    from benchbot.core.session import resolve_run, start_service
    from benchbot.plugins.recorder import attach_recorder, detach_recorder

    reg = get_registry()
    run_spec = resolve_run(reg, "semantic_slam:passive:ground_truth", "carter", "miniroom:4")
    service = start_service(reg, run_spec, seed=0, options={"width": 64, "height": 48})
    try:
        recorder = attach_recorder(reg, service, run_spec, tmp_path / "episode.mcap", seed=0,
                                   options={"width": 64, "height": 48})
        bot = BenchBot(backend=service)
        _, result = bot.reset()
        while result == ActionResult.SUCCESS:
            _, result = bot.step("move_next")
        mcap = detach_recorder(reg, service, recorder)
    finally:
        service.close()
    run = load_run(scores_only_run(tmp_path, "recorded", {"miniroom:4": [0.3]}))
    (run.run_dir / "recordings").mkdir()
    stem = Path(run.manifest["plan"][0]["results"]).stem
    shutil.copy(mcap, run.run_dir / "recordings" / f"{stem}.mcap")
    path, source = driven_path(run, run.rows[0])
    plan = reg.scenes("miniroom:4")[0]["trajectory_poses"]
    assert source == "recording" and len(path) >= len(plan)
    assert path[-1] == pytest.approx([plan[-1][4], plan[-1][5]], abs=0.05)
