"""Evaluators declare their scores (names, the primary one, direction, range, description), and every view reads
the declaration instead of OMQ's names: the report, the leaderboard, `benchbot eval`'s table, the batch's live
table and closing line, sweeps. Tested with a second evaluation method defined in the tests (tests/second_evaluator.py),
whose primary score is lower-is-better."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

from benchbot.batch.analysis import analyse
from benchbot.batch.leaderboard import entries
from benchbot.batch.run_conditions import provenance_rows
from benchbot.batch.run_data import assign_labels, load_run
from benchbot.core.evaluation import ScoreSet, evaluate, method_scores, observed_scores
from benchbot.core.registry import Registry

sys.path.insert(0, str(Path(__file__).parent))
from report_runs import TASK, make_run  # noqa: E402
from second_evaluator import ReachPlugin, TwoPrimariesPlugin, UndeclaredPlugin  # noqa: E402


@pytest.fixture(scope="module")
def reg():
    return Registry(extra_plugins={"reach": ReachPlugin(), "reach_undeclared": UndeclaredPlugin(),
                                   "reach_two": TwoPrimariesPlugin()})


def test_the_declaration_is_validated_and_read(reg):
    declared = method_scores(reg, "reach")
    assert (declared.primary.name, declared.primary.direction, declared.sign()) == ("miss_m", "lower", -1)
    assert declared.scores == ["miss_m", "reached"] and declared.counts == ["proposals"]
    assert declared.get("miss_m").range == (0.0, None) and declared.get("miss_m").heading == "miss"
    omq = method_scores(reg, "omq")
    assert (omq.primary.name, omq.sign(), omq.counts) == ("OMQ", 1, ["TP", "FP", "FN"])
    assert method_scores(reg, "reach_undeclared") is None
    assert "reach_two" not in reg.names("evaluators")  # two primary scores: the schema refuses the spec
    problems = " ".join(str(p) for info in reg.plugins if info.name == "reach_two" for p in info.problems)
    assert "$.scores: 2 scores are primary (miss_m, reached)" in problems
    assert ScoreSet.from_json(declared.to_json()) == declared


def test_undeclared_scores_are_read_from_what_the_method_returns():
    seen = observed_scores("x", [{"miss_m": 0.4, "reached": 0.5, "proposals": 12}, {"proposals": 3}])
    assert (seen.primary.name, seen.declared, seen.counts) == ("miss_m", False, ["proposals"])
    with pytest.raises(ValueError):
        observed_scores("x", [{"name": "not a number"}])



@pytest.mark.parametrize("bad", [[[1], 2], 5, ["low", 1]])
def test_a_recorded_declaration_with_a_bad_range_is_a_value_error(bad):
    with pytest.raises(ValueError, match="range .* is not \\[low, high\\]"):
        ScoreSet.from_json({"method": "m", "scores": [{"name": "s", "range": bad}]})

@pytest.fixture(scope="module")
def runs(reg, tmp_path_factory):
    root = tmp_path_factory.mktemp("reach")
    good = make_run(root, "close", {"miniroom:1": [0.95, 0.9], "miniroom:2": [0.9]}, method="reach", registry=reg,
                    example="close")
    poor = make_run(root, "far", {"miniroom:1": [0.5, 0.45], "miniroom:2": [0.4]}, method="reach", registry=reg,
                    example="far")
    out = [load_run(poor), load_run(good)]
    assign_labels(out, None)
    return out


def test_report_compares_on_the_declared_primary_score(runs, reg):
    far, close = runs
    assert close.score_set.primary.name == "miss_m" and "OMQ" not in close.rows[0]
    result = analyse(runs, reg)
    assert result["main_score"] == "miss_m" and list(result["runs"][0]["summary"]) == ["miss_m", "reached"]
    [c] = result["comparisons"]
    assert c["score"] == "miss_m" and c["direction"] == "lower" and c["difference"]["value"] < 0  # close misses less
    assert "gives no per-class scores" in result["runs"][0]["objects_note"]
    assert "primary score miss_m, lower is better" in dict(provenance_rows(close))["evaluation"]


def test_leaderboard_ranks_lower_is_better_first(runs):
    [[table]] = entries(runs).values()
    assert (table["score"], table["direction"]) == ("miss_m", "lower")
    assert [(e["label"], e["rank"]) for e in table["entries"]] == [("close", 1), ("far", 2)]
    assert table["conditions"]["evaluation"] == "reach"


def test_eval_table_and_the_batch_closing_line_name_the_declared_scores(reg, runs, capsys):
    from benchbot.cli.batch_cmd import batch_summary
    from benchbot.cli.eval_cmd import print_scores

    close = runs[1]
    files = sorted(str(p) for p in (close.run_dir / "results").glob("*.json"))
    evaluation = evaluate(files, "reach", reg, required_task=TASK)
    assert evaluation.score_set.primary.name == "miss_m"
    print_scores(evaluation)
    header = next(line for line in capsys.readouterr().out.splitlines() if "environment" in line)
    assert header.index("miss") < header.index("reached") < header.index("proposals")
    outcome = SimpleNamespace(episodes=[SimpleNamespace(status="ok")] * 3, evaluation=evaluation)
    line = batch_summary(outcome, 12.0)
    assert "; miss_m 0." in line and "OMQ" not in line


def test_the_batch_table_heads_its_score_column_with_the_primary_score(runs):
    from benchbot.tui.batch_app import batch_rows, primary_score

    close = runs[1]
    summary, rows = batch_rows(close.run_dir)
    assert summary["score_name"] == "miss_m" and rows[0][-1] == f"{close.rows[0]['miss_m']:.4f}"
    assert summary["combined"] == pytest.approx(json.loads((close.run_dir / "scores.json").read_text())["scores"]["miss_m"])
    assert primary_score({"evaluate_with": "reach"}, [{"index": 0, "scores": {"miss_m": 0.3, "proposals": 4}}]) == "miss_m"


def test_a_sweep_plots_the_declared_primary_score(runs, tmp_path):
    from benchbot.batch.sweep import robustness_from_run

    close = runs[1]
    manifest = json.loads((close.run_dir / "manifest.json").read_text())
    manifest["sweep"] = {"factor": "noise", "levels": ["none"], "level_of": {str(p["index"]): "none"
                                                                          for p in manifest["plan"]}}
    (close.run_dir / "manifest.json").write_text(json.dumps(manifest))
    summary = robustness_from_run(close.run_dir)
    assert summary["score"] == "miss_m" and summary["levels"][0]["episodes"]["n"] == 3


def test_a_method_without_a_declaration_still_gets_views(reg, tmp_path):
    run = load_run(make_run(tmp_path, "old", {"miniroom:1": [0.9]}, method="reach_undeclared", registry=reg))
    assert (run.primary, run.score_set.declared) == ("miss_m", False)  # the first real-valued score it returned
    assert "not declared by the method: assumed" in dict(provenance_rows(run))["evaluation"]


def test_the_contract_check_holds_a_method_to_its_declaration(reg):
    from benchbot.plugins.testing import check_evaluator

    from second_evaluator import SPEC
    from report_runs import results_file

    results = results_file("miniroom:1", 0.9, 0)
    gts = [reg.ground_truth("miniroom:1")]
    assert check_evaluator(dict(SPEC), results, gts)["scores"]["proposals"] > 0
    wrong = dict(SPEC, scores=[dict(SPEC["scores"][0], name="missed_m")] + SPEC["scores"][1:])
    with pytest.raises(AssertionError, match="declares score 'missed_m' but evaluate returned scores.missed_m = None"):
        check_evaluator(wrong, results, gts)
    narrow = dict(SPEC, scores=[dict(SPEC["scores"][0], range=[0, 0.001])] + SPEC["scores"][1:])
    with pytest.raises(AssertionError, match="outside its declared range"):
        check_evaluator(narrow, results, gts)
