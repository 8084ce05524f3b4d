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

import pytest

from benchbot.batch import stats
from benchbot.batch.report import (
    analyse, assign_labels, compare, comparisons, default_label, factor_views, load_run, pair_episodes,
    per_class_rows, write_report,
)
from benchbot.core.errors import UsageError
from benchbot.core.registry import get_registry

sys.path.insert(0, str(Path(__file__).parent))
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
    assert result["runs"][0]["summary"]["OMQ"]["n"] == 9 and result["runs"][0]["summary"]["OMQ"]["low"] is not None
    assert result["policy"]["min_ci_n"] == stats.MIN_CI_N == 5


def test_pairs_by_environment_and_seed_else_by_repetition(tmp_path):
    a = load_run(scores_only_run(tmp_path, "a", {"miniroom:1": [0.2, 0.3], "house:1": [0.25], "house:9": [0.9]}))
    b = load_run(scores_only_run(tmp_path, "b", {"miniroom:1": [0.4, 0.5], "house:1": [0.5]}))
    pairs = pair_episodes(a, b)
    assert pairs["pairing"] == "environment and seed"
    assert pairs["keys"] == ["miniroom:1 s0", "miniroom:1 s1", "house:1 s2"]
    assert (pairs["a"], pairs["b"], pairs["unpaired"]) == ([0.2, 0.3, 0.25], [0.4, 0.5, 0.5], 1)
    shifted = load_run(scores_only_run(tmp_path, "c", {"miniroom:1": [0.4, 0.5], "house:1": [0.5]}, seed=100))
    pairs = pair_episodes(a, shifted)
    assert pairs["pairing"] == "environment and repetition (the seeds differ)" and len(pairs["a"]) == 3
    c = compare(a, b)
    assert c["n"] == 3 and c["ttest_p"] is None and c["reason"] == "n = 3 < 6: no paired test"
    assert c["difference"]["value"] == pytest.approx((0.2 + 0.2 + 0.25) / 3)


def test_comparisons_have_effect_sizes_and_holm_adjusted_p_values(tmp_path):
    base = {f"miniroom:{v}": [0.20 + 0.01 * v, 0.22 + 0.01 * v] for v in range(1, 5)}  # 8 pairs
    better = {e: [x + 0.05 + 0.004 * k for k, x in enumerate(v)] for e, v in base.items()}
    same = {e: [x + (0.002 if k else -0.003) for k, x in enumerate(v)] for e, v in base.items()}
    runs = [load_run(scores_only_run(tmp_path, n, d)) for n, d in (("a", base), ("b", better), ("c", same))]
    assign_labels(runs, ["baseline", "better", "same"])
    out = comparisons(runs)
    assert [c["b"] for c in out] == ["better", "same"] and all(c["n"] == 8 for c in out)
    raw = [c["ttest_p"] for c in out]
    assert [c["ttest_p_holm"] for c in out] == pytest.approx(stats.holm(raw))
    assert out[0]["ttest_p_holm"] == pytest.approx(min(1.0, 2 * min(raw)))  # the smaller p is doubled
    assert out[0]["cohens_dz"] > 1 and out[0]["rank_biserial"] == 1.0 and out[0]["ttest_p"] < 0.001
    assert out[0]["difference"]["low"] > 0


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
    assert sum(r["GT"] for r in rows) == 2 * len(gt) + len(gt2)
    assert sum(r["FN"] for r in rows) == 2 * (len(gt) // 5) + len(gt2) // 5  # every fifth object is missed
    assert sum(r["FP"] for r in rows) == 3 * 2
    matches = run.objects[0]["matches"]
    assert len(matches["ground_truth"]) == len(gt) and {p["status"] for p in matches["proposals"]} <= {"TP", "FP", "group"}


@pytest.mark.slow
def test_report_files_for_papers(tmp_path):
    a = load_run(make_run(tmp_path, "batch-20261122-100000", {"miniroom:1": [0.9, 0.85], "miniroom:2": [0.8]}))
    b = load_run(make_run(tmp_path, "batch-20261122-110000", {"miniroom:1": [0.6, 0.65], "miniroom:2": [0.7]},
                          example="hello_active"))
    assign_labels([a, b], None)
    output = tmp_path / "out" / "report.html"
    write_report([a, b], output, get_registry())
    page = output.read_text()
    files = output.parent / "report_files"
    for stem in ("summary", "environments", "comparison_1", "per_class_1", "per_class_2", "map_miniroom_1",
                 "map_miniroom_2"):
        assert (files / f"{stem}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert (files / f"{stem}.pdf").read_bytes()[:5] == b"%PDF-"
        ET.fromstring((files / f"{stem}.svg").read_bytes())  # well-formed SVG
        assert f"report_files/{stem}.svg" in page and f"report_files/{stem}.pdf" in page
    with (files / "summary.csv").open() as f:
        rows = list(csv.reader(f))
    assert rows[0][:5] == ["run", "episodes", "OMQ", "OMQ low", "OMQ high"]
    assert rows[1][0] == "semslam_geometric" and float(rows[1][2]) == pytest.approx(a.rows[0]["OMQ"] / 3
                                                                                     + a.rows[1]["OMQ"] / 3
                                                                                     + a.rows[2]["OMQ"] / 3)
    tex = (files / "per_class_1.tex").read_text()
    assert tex.startswith("\\begin{table}") and "\\toprule" in tex and "potted plant" in tex and "\\_" not in "x"
    assert "\\label{tab:summary}" in (files / "summary.tex").read_text()
    # the page: labels instead of timestamps in the legends, n stated, provenance, statistics policy
    assert "semslam_geometric" in page and "hello_active" in page and "0123456789abcdef" in page
    assert "n = 3 &lt; 6: no paired test" in page and "How to read the numbers" in page
    assert "Test CPU, 2 CPUs, 8 GiB" in page and "benchbot batch --example semslam_geometric" in page
    assert page.count("data:image/png;base64,") == 7
    assert json.loads((files / "report.json").read_text())["comparisons"][0]["n"] == 3
    assert too_precise(re.sub(r"data:image/png;base64,[^']*", "", page)) == []


@pytest.mark.slow
def test_cli_prints_rounded_numbers_and_refusals(tmp_path):
    a = scores_only_run(tmp_path, "a", {"miniroom:1": [0.16012345678], "miniroom:2": [0.3]})
    b = scores_only_run(tmp_path, "b", {"miniroom:1": [0.1578656], "miniroom:2": [0.3001]})
    proc = cli("report", str(a), str(b))
    assert proc.returncode == 0, proc.stderr
    assert "0.1601" in proc.stdout and "n = 1 < 5: no confidence interval" in proc.stdout
    assert "mean difference -0.001079" in proc.stdout  # (-0.002258 + 0.0001) / 2 and "n = 2 < 6: no paired test" in proc.stdout
    assert too_precise(proc.stdout) == [], proc.stdout
    proc = cli("report", str(a), str(b), "--json", "--label", "A", "--label", "B")
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    assert [r["label"] for r in result["runs"]] == ["A", "B"]
    assert result["comparisons"][0]["ttest_p"] is None


@pytest.mark.slow
def test_report_errors_are_one_line(tmp_path):
    proc = cli("report", str(tmp_path))
    assert proc.returncode == 2 and "is not a batch run directory" in proc.stderr and "Traceback" not in proc.stderr
    run = scores_only_run(tmp_path, "a", {"miniroom:1": [0.1]})
    (run / "episode_scores.json").write_text(json.dumps([{"index": 0, "env": "miniroom:1"}]))
    proc = cli("report", str(run))
    assert proc.returncode == 2 and "episode_scores.json: malformed ([0].robot)" in proc.stderr
    assert "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 2  # error + hint
    (run / "episode_scores.json").write_text("[1, 2")
    proc = cli("report", str(run))
    assert proc.returncode == 2 and "episode_scores.json is unreadable or not JSON" in proc.stderr
    good = scores_only_run(tmp_path, "b", {"miniroom:1": [0.1]})
    proc = cli("report", str(good), "--label", "x", "--label", "y")
    assert proc.returncode == 2 and "--label: 2 labels for 1 run directories" in proc.stderr
    (tmp_path / "a_file").write_text("")
    proc = cli("report", str(good), "-o", str(tmp_path / "a_file" / "report.html"))
    assert proc.returncode == 2 and "--output: cannot write" in proc.stderr and "Traceback" not in proc.stderr
