"""benchbot leaderboard: a static site (index, one sortable page per task, each entry's manifest and report), ranks
only among entries on the same environments, and one-line errors."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from benchbot.batch.leaderboard import entries, slug, write_site
from benchbot.batch.report import assign_labels, load_run

sys.path.insert(0, str(Path(__file__).parent))
from report_runs import make_run, scores_only_run  # noqa: E402

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]


def cli(*args):
    return subprocess.run([*BENCHBOT, *args], capture_output=True, text=True, timeout=300)


def test_ranks_by_mean_omq_among_entries_on_the_same_environments(tmp_path):
    envs = {"miniroom:1": [0.2, 0.3], "miniroom:2": [0.25]}
    runs = [load_run(scores_only_run(tmp_path, "a", envs, example="low")),
            load_run(scores_only_run(tmp_path, "b", {e: [v + 0.3 for v in vs] for e, vs in envs.items()}, example="high")),
            load_run(scores_only_run(tmp_path, "c", {"miniroom:1": [0.9]}, example="partial"))]
    assign_labels(runs, None)
    [(task, rows)] = entries(runs).items()
    assert task == "semantic_slam:passive:ground_truth"
    assert [(e["label"], e["rank"], e["covers"]) for e in rows] == [("high", 1, True), ("low", 2, True),
                                                                    ("partial", None, False)]
    assert abs(rows[0]["scores"]["OMQ"]["value"] - (0.5 + 0.6 + 0.55) / 3) < 1e-12
    site = write_site(runs, tmp_path / "site", reports=False)
    page = (tmp_path / "site" / f"{slug(task)}.html").read_text()
    assert "table class='sortable'" in page and "<script>" in page and "aria-sort" in page
    assert "1 entry does not cover the ranked environments" in page
    assert "2 environments: miniroom:1, miniroom:2" in page
    # the mean with its n (and why no interval), its raw value for sorting
    assert re.search(r"data-v='0\.55[0-9]*' title='n = 3 &lt; 5: no confidence interval'>0\.55<br><small>n = 3<", page)
    assert not re.search(r"(src|href)=['\"]https?://", page)  # nothing from elsewhere: works offline, forever
    for e in rows:
        assert (tmp_path / "site" / "entries" / e["slug"] / "manifest.json").is_file()
        assert f"entries/{e['slug']}/manifest.json" in page
    index = (tmp_path / "site" / "index.html").read_text()
    assert f"href='{slug(task)}.html'" in index and "3 entries" in index
    data = json.loads((tmp_path / "site" / "leaderboard.json").read_text())
    assert [e["rank"] for e in data["tasks"][task]] == [1, 2, None] and site["tasks"] == data["tasks"]


def test_entries_are_ranked_on_one_set_of_environments(tmp_path):
    runs = [load_run(scores_only_run(tmp_path, "a", {"miniroom:1": [0.2], "miniroom:2": [0.4]}, example="a")),
            load_run(scores_only_run(tmp_path, "b", {"miniroom:1": [0.3], "miniroom:2": [0.25]}, example="b")),
            load_run(scores_only_run(tmp_path, "c", {"miniroom:1": [0.1], "miniroom:2": [0.1], "house:1": [0.9]},
                                     example="c")),
            load_run(scores_only_run(tmp_path, "d", {"house:1": [0.9]}, example="d"))]
    assign_labels(runs, None)
    [rows] = entries(runs).values()
    assert rows[0]["benchmark"] == ["miniroom:1", "miniroom:2"]  # the set most entries ran
    # c covers it (and more): scored on its miniroom episodes only, 0.1, not 0.367; d does not: not ranked
    assert [(e["label"], e["rank"]) for e in rows] == [("a", 1), ("b", 2), ("c", 3), ("d", None)]
    assert rows[2]["scores"]["OMQ"]["value"] == 0.1 and rows[2]["episodes"] == 2
    [rows] = entries(runs, ["house:1"]).values()
    assert [(e["label"], e["rank"]) for e in rows if e["rank"]] == [("c", 1), ("d", 2)]


def test_runs_without_the_sandbox_are_marked_and_not_ranked(tmp_path):
    """A run whose solution could read the ground truth (--no-sandbox, or a batch from before the sandbox) is listed
    as not verifiable and never ranked, however high it scores; its report says so too."""
    from benchbot.batch.report import analyse, render_html

    runs = [load_run(scores_only_run(tmp_path, "a", {"miniroom:1": [0.2]}, example="honest")),
            load_run(scores_only_run(tmp_path, "b", {"miniroom:1": [0.99]}, example="copied", sandbox="none"))]
    assign_labels(runs, None)
    [(task, rows)] = entries(runs).items()
    assert [(e["label"], e["rank"], e["verifiable"]) for e in rows] == [("honest", 1, True), ("copied", None, False)]
    write_site(runs, tmp_path / "site", reports=False)
    page = (tmp_path / "site" / f"{slug(task)}.html").read_text()
    assert "copied (not verifiable)" in page and "1 entry is not verifiable" in page
    result = analyse(runs)
    assert [r["verifiable"] for r in result["runs"]] == [True, False]
    assert result["runs"][1]["provenance"]["isolation"].startswith("none (NOT VERIFIABLE")
    html = render_html(runs, result, [], [], "assets")
    assert "Not verifiable:</b> copied ran its solution without the sandbox" in html


@pytest.mark.slow
def test_cli_writes_the_site_with_each_entrys_report(tmp_path):
    a = make_run(tmp_path, "a", {"miniroom:1": [0.9]})
    b = scores_only_run(tmp_path, "b", {"miniroom:1": [0.3]}, example="other")
    site = tmp_path / "site"
    proc = cli("leaderboard", str(a), str(b), "-o", str(site), "--label", "ours", "--label", "theirs",
               "--title", "Semantic SLAM challenge")
    assert proc.returncode == 0, proc.stderr
    page = (site / "semantic_slam-passive-ground_truth.html").read_text()
    assert "Semantic SLAM challenge" in page and ">ours<" in page and ">theirs<" in page
    reports = sorted(site.glob("entries/*/report.html"))
    assert len(reports) == 2 and all("BenchBot performance profile" in r.read_text() for r in reports)
    assert list(site.glob("entries/ours-a/report_files/map_miniroom_1.svg"))
    proc = cli("leaderboard", str(a), "-o", str(tmp_path / "a" / "manifest.json"))
    assert proc.returncode == 2 and "is a file" in proc.stderr and "Traceback" not in proc.stderr
    proc = cli("leaderboard", str(tmp_path / "nothing"), "-o", str(site))
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
