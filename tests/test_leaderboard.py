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
from benchbot.batch.run_data import assign_labels, load_run

sys.path.insert(0, str(Path(__file__).parent))
import report_runs  # noqa: E402
from cli_in_process import benchbot  # noqa: E402
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
    [(task, [table])] = entries(runs).items()
    rows = table["entries"]
    assert task == "semantic_slam:passive:ground_truth" and (table["score"], table["direction"]) == ("OMQ", "higher")
    assert [(e["label"], e["rank"], e["covers"]) for e in rows] == [("high", 1, True), ("low", 2, True),
                                                                    ("partial", None, False)]
    # the environment is the unit: the mean of miniroom:1's (0.55) and miniroom:2's (0.55) means
    assert abs(rows[0]["scores"]["OMQ"]["value"] - (0.55 + 0.55) / 2) < 1e-12 and rows[0]["scores"]["OMQ"]["n"] == 2
    site = write_site(runs, tmp_path / "site", reports=False)
    page = (tmp_path / "site" / f"{slug(task)}.html").read_text()
    assert "table class='sortable'" in page and "<script>" in page and "aria-sort" in page
    assert "1 entry does not cover the ranked environments" in page
    assert "2 environments: miniroom:1, miniroom:2" in page
    assert "ordered by their mean alone" in page  # 2 environments: no interval
    # the mean with its n (and why no interval), its raw value for sorting
    assert re.search(r"data-v='0\.55[0-9]*' title='n = 2 &lt; 5: no confidence interval over environments'>"
                     r"0\.55<br><small>n = 2<", page)
    assert not re.search(r"(src|href)=['\"]https?://", page)  # nothing from elsewhere: works offline, forever
    for e in rows:
        assert (tmp_path / "site" / "entries" / e["slug"] / "manifest.json").is_file()
        assert f"entries/{e['slug']}/manifest.json" in page
    index = (tmp_path / "site" / "index.html").read_text()
    assert f"href='{slug(task)}.html'" in index and "3 entries" in index
    data = json.loads((tmp_path / "site" / "leaderboard.json").read_text())
    assert [e["rank"] for e in data["tasks"][task][0]["entries"]] == [1, 2, None] and site["tasks"] == data["tasks"]


def test_entries_are_ranked_on_one_set_of_environments(tmp_path):
    runs = [load_run(scores_only_run(tmp_path, "a", {"miniroom:1": [0.2], "miniroom:2": [0.4]}, example="a")),
            load_run(scores_only_run(tmp_path, "b", {"miniroom:1": [0.3], "miniroom:2": [0.25]}, example="b")),
            load_run(scores_only_run(tmp_path, "c", {"miniroom:1": [0.1], "miniroom:2": [0.1], "house:1": [0.9]},
                                     example="c")),
            load_run(scores_only_run(tmp_path, "d", {"house:1": [0.9]}, example="d"))]
    assign_labels(runs, None)
    [[table]] = entries(runs).values()
    rows = table["entries"]
    assert table["benchmark"] == ["miniroom:1", "miniroom:2"]  # the set most entries ran
    # c covers it (and more): scored on its miniroom episodes only, 0.1, not 0.367; d does not: not ranked
    assert [(e["label"], e["rank"]) for e in rows] == [("a", 1), ("b", 2), ("c", 3), ("d", None)]
    assert rows[2]["scores"]["OMQ"]["value"] == 0.1 and rows[2]["episodes"] == 2
    [[table]] = entries(runs, ["house:1"]).values()
    assert [(e["label"], e["rank"]) for e in table["entries"] if e["rank"]] == [("c", 1), ("d", 1)]  # both 0.9


def test_one_table_per_condition_set(tmp_path):
    """Entries run with another noise preset, robot, camera, scene style or simulator version are never ranked
    against each other: each condition set is its own table."""
    envs = {"miniroom:1": [0.3]}
    runs = [load_run(scores_only_run(tmp_path, "a", envs, example="a")),
            load_run(scores_only_run(tmp_path, "b", {"miniroom:1": [0.9]}, example="b", noise="high")),
            load_run(scores_only_run(tmp_path, "c", {"miniroom:1": [0.8]}, example="c", robot="turtlebot4")),
            load_run(scores_only_run(tmp_path, "d", {"miniroom:1": [0.7]}, example="d",
                                     backend=dict(report_runs.BACKEND, style="furnished"))),
            load_run(scores_only_run(tmp_path, "e", {"miniroom:1": [0.6]}, example="e",
                                     backend=dict(report_runs.BACKEND, version="0.2.0"))),
            load_run(scores_only_run(tmp_path, "f", envs, example="f"))]
    plan = json.loads((runs[5].run_dir / "manifest.json").read_text())
    for p in plan["plan"]:
        p["options"] = {"width": 320, "height": 240}
    (runs[5].run_dir / "manifest.json").write_text(json.dumps(plan))
    runs[5] = load_run(runs[5].run_dir)
    assign_labels(runs, None)
    [tables] = entries(runs).values()
    assert len(tables) == 6 and all(len(t["entries"]) == 1 and t["entries"][0]["rank"] == 1 for t in tables)
    by_label = {t["entries"][0]["label"]: t["conditions"] for t in tables}
    assert by_label["b"]["noise preset"] == "high" and by_label["c"]["robot"] == "turtlebot4"
    assert by_label["d"]["simulator style"] == "furnished" and by_label["f"]["camera"] == "320x240"
    assert by_label["e"]["simulator"] == "benchbot-sim-taichi 0.2.0"
    assert by_label["a"] == {"robot": "carter", "noise preset": "none", "camera": "not recorded",
                             "simulator": "benchbot-sim-taichi 0.1.0", "simulator style": "primitives",
                             "isolation": "bwrap", "evaluation": "omq", "ground truth": "not recorded"}
    write_site(runs, tmp_path / "site", reports=False)
    page = (tmp_path / "site" / "semantic_slam-passive-ground_truth.html").read_text()
    assert page.count("<table class='sortable'>") == 6 and "6 entries in 6 condition sets" in page


def test_entries_the_intervals_do_not_tell_apart_share_a_rank(tmp_path):
    envs = [f"miniroom:{v}" for v in range(1, 6)] + ["house:1"]
    spread = [0.0, 0.05, -0.05, 0.1, -0.1, 0.02]
    best = {e: [0.6 + d] for e, d in zip(envs, spread)}
    close = {e: [0.58 + d] for e, d in zip(envs, spread[::-1])}
    far = {e: [0.2 + d / 2] for e, d in zip(envs, spread)}
    runs = [load_run(scores_only_run(tmp_path, n, d, example=n)) for n, d in (("far", far), ("close", close),
                                                                             ("best", best))]
    assign_labels(runs, None)
    [[table]] = entries(runs).values()
    rows = table["entries"]
    assert [(e["label"], e["rank"], e["tied"]) for e in rows] == [("best", 1, True), ("close", 1, True),
                                                                  ("far", 3, False)]
    assert rows[0]["scores"]["OMQ"]["low"] < rows[1]["scores"]["OMQ"]["high"]  # the intervals overlap
    write_site(runs, tmp_path / "site", reports=False)
    page = (tmp_path / "site" / "semantic_slam-passive-ground_truth.html").read_text()
    assert ">1=<" in page and "share a rank" in page and ">3<" in page


def test_runs_without_the_sandbox_are_marked_and_not_ranked(tmp_path):
    """A run whose solution could read the ground truth (--no-sandbox, or a batch from before the sandbox) is listed
    as not verifiable and never ranked, however high it scores; its report says so too."""
    from benchbot.batch.analysis import analyse
    from benchbot.batch.report import render_html

    runs = [load_run(scores_only_run(tmp_path, "a", {"miniroom:1": [0.2]}, example="honest")),
            load_run(scores_only_run(tmp_path, "b", {"miniroom:1": [0.99]}, example="copied", sandbox="none"))]
    assign_labels(runs, None)
    [(task, tables)] = entries(runs).items()
    assert [[(e["label"], e["rank"], e["verifiable"]) for e in t["entries"]] for t in tables] == [
        [("honest", 1, True)], [("copied", None, False)]]  # isolation is a condition: its own table, unranked
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
    b = make_run(tmp_path, "b", {"miniroom:1": [0.3]}, example="other")  # with its results: re-scored, as recorded
    stopped = scores_only_run(tmp_path, "stopped", {"miniroom:1": [0.3, 0.4]}, example="killed")
    manifest = json.loads((stopped / "manifest.json").read_text())
    manifest["episodes"][1]["status"] = "running"
    (stopped / "manifest.json").write_text(json.dumps(manifest))
    (stopped / "episode_scores.json").unlink()
    site = tmp_path / "site"
    proc = cli("leaderboard", str(a), str(stopped), str(b), "-o", str(site), "--label", "ours", "--label", "killed",
               "--label", "theirs", "--title", "Semantic SLAM challenge")
    assert proc.returncode == 0, proc.stderr
    said = proc.stderr.splitlines()  # into a log: a plain line per step, never a silence
    assert said[0] == "reading run directory 1 of 3 …" and "writing entry 2 of 2's report: theirs …" in said, said
    assert "\x1b[" not in proc.stderr
    # the interrupted batch: one line naming --resume, and the rest is built
    [line] = [x for x in proc.stderr.splitlines() if "stopped" in x]
    assert "skipped" in line and "did not finish (1 of 2 episodes not run)" in line
    assert f"benchbot batch --resume {stopped}" in line and "--evaluate-with" not in proc.stderr
    page = (site / "semantic_slam-passive-ground_truth.html").read_text()
    assert "Semantic SLAM challenge" in page and ">ours<" in page and ">theirs<" in page and "killed" not in page
    assert "Left out (unfinished, or every episode failed)" in (site / "index.html").read_text()
    reports = sorted(site.glob("entries/*/report.html"))
    assert len(reports) == 2 and all("BenchBot performance profile" in r.read_text() for r in reports)
    assert list(site.glob("entries/ours-a/report_files/map_miniroom_1.svg"))
    proc = cli("leaderboard", str(a), "-o", str(tmp_path / "a" / "manifest.json"))
    assert proc.returncode == 2 and "is a file" in proc.stderr and "Traceback" not in proc.stderr
    proc = cli("leaderboard", str(tmp_path / "nothing"), "-o", str(site))
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    proc = cli("leaderboard", str(stopped), "-o", str(site))
    assert proc.returncode == 2 and "no finished run directory with scores" in proc.stderr


def test_a_batch_whose_every_episode_failed_is_skipped_with_a_note(tmp_path):
    good = scores_only_run(tmp_path, "good", {"miniroom:1": [0.6]})
    failed = scores_only_run(tmp_path, "failed", {"miniroom:1": [0.3, 0.4]}, example="broken")
    manifest = json.loads((failed / "manifest.json").read_text())
    for e in manifest["episodes"]:
        e.update(status="failed", returncode=1)
    manifest["finished"] = "2026-11-25T00:00:00+00:00"
    (failed / "manifest.json").write_text(json.dumps(manifest))
    (failed / "episode_scores.json").unlink()
    site = tmp_path / "site"
    proc = benchbot("leaderboard", str(good), str(failed), "-o", str(site), "--no-reports")
    assert proc.returncode == 0, proc.stderr
    [line] = [x for x in proc.stderr.splitlines() if "failed" in x]
    assert line.startswith("skipped ") and "every episode failed, 2 of 2 (first: miniroom:1: exit status 1; log " in line
    assert f"benchbot batch --resume {failed} runs them again" in line and "--evaluate-with" not in proc.stderr
    assert "every episode failed, 2 of 2" in (site / "index.html").read_text()
    proc = benchbot("leaderboard", str(failed), "-o", str(tmp_path / "site2"))
    assert proc.returncode == 2 and "no finished run directory with scores among the 1 given" in proc.stderr


# --- verified and self-reported entries (signed runs, docs/challenge.md) -------------------------------------------
def signed_run(root: Path, name: str, omq: dict[str, list[float]], key: Path | None, **kwargs) -> Path:
    """A finished run with a scores.json, signed with the private key ``key`` (None: left unsigned)."""
    from benchbot.batch.signing import sign_run

    run = scores_only_run(root, name, omq, manifest={"finished": "2026-11-26T00:00:00+00:00"}, **kwargs)
    values = [v for vs in omq.values() for v in vs]
    (run / "scores.json").write_text(json.dumps({"scores": {"OMQ": sum(values) / len(values)}}))
    if key is not None:
        sign_run(run, key)
    return run


def test_verified_entries_are_ranked_apart_from_self_reported_ones(tmp_path):
    """A run signed by a trusted key on held-out worlds is verified and ranked in its own table; an unsigned run,
    however high, is self-reported; an edited signed run fails verification and is not ranked; a run signed by
    another key is self-reported; a signed run on public worlds is 'development — ground truth public'."""
    from benchbot.batch.signing import DEVELOPMENT, load_public_key, write_key_pair

    host, host_pub = write_key_pair(tmp_path / "host")
    other, _ = write_key_pair(tmp_path / "other")
    test = {"procedural_test_0:1": [0.3], "procedural_test_1:1": [0.4]}
    paths = {"honest": signed_run(tmp_path, "a", test, host, example="honest"),
             "claimed": signed_run(tmp_path, "b", {e: [0.99] for e in test}, None, example="claimed"),
             "edited": signed_run(tmp_path, "c", test, host, example="edited"),
             "elsewhere": signed_run(tmp_path, "d", {e: [0.5] for e in test}, other, example="elsewhere"),
             "public": signed_run(tmp_path, "e", {"miniroom:1": [0.9]}, host, example="public")}
    scores = paths["edited"] / "episode_scores.json"
    scores.write_text(scores.read_text().replace('"OMQ": 0.3', '"OMQ": 0.9'))  # an edited byte of a signed run
    runs = [load_run(p) for p in paths.values()]
    assign_labels(runs, None)
    trusted = [load_public_key(host_pub)]
    [(task, tables)] = entries(runs, trusted=trusted).items()
    status = {e["label"]: (t["standing"], e["status"], e["rank"]) for t in tables for e in t["entries"]}
    assert tables[0]["standing"] == "verified" and [e["label"] for e in tables[0]["entries"]] == ["honest"]
    assert status == {"honest": ("verified", "verified", 1), "claimed": ("self-reported", "self-reported", 1),
                      "elsewhere": ("self-reported", "self-reported", 2), "edited": ("self-reported", "failed", None),
                      "public": ("self-reported", "development", None)}  # other worlds: not ranked
    site = write_site(runs, tmp_path / "site", reports=False, trusted=trusted)
    page = (tmp_path / "site" / f"{slug(task)}.html").read_text()
    assert "Verified: conditions 1" in page and "Self-reported: conditions 2" in page
    assert "edited (fails verification)" in page and "episode_scores.json: changed since it was signed" in page
    assert DEVELOPMENT in page and "never with verified entries" in page
    assert (tmp_path / "site" / "entries").glob("*/signature.json")
    [verified] = site["tasks"][task][0]["entries"]
    assert verified["status"] == "verified" and verified["worlds"] == "held-out"
    # no trusted key: nothing is verified, whatever it carries
    assert all(t["standing"] == "self-reported" for t in entries(runs)[task])
    proc = benchbot("leaderboard", *map(str, paths.values()), "-o", str(tmp_path / "s2"), "--no-reports",
                    "--trusted-key", str(host_pub))
    assert proc.returncode == 0, proc.stderr
    proc = benchbot("leaderboard", str(paths["honest"]), "-o", str(tmp_path / "s3"), "--trusted-key", str(scores))
    assert proc.returncode == 2 and "episode_scores.json: not an Ed25519 public key" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_the_report_labels_runs_on_public_worlds_as_development(tmp_path):
    """`benchbot report` says which runs ran on public worlds (ground truth public) and which on held-out ones."""
    from benchbot.batch.analysis import analyse
    from benchbot.batch.report import render_html
    from benchbot.batch.signing import DEVELOPMENT, HELD_OUT

    runs = [load_run(scores_only_run(tmp_path, "a", {"procedural_test_0:1": [0.2]}, example="held")),
            load_run(scores_only_run(tmp_path, "b", {"miniroom:1": [0.9]}, example="public"))]
    assign_labels(runs, None)
    result = analyse(runs)
    assert [r["worlds"] for r in result["runs"]] == [HELD_OUT, DEVELOPMENT]
    assert result["runs"][1]["provenance"]["worlds"] == DEVELOPMENT
    html = render_html(runs, result, [], [], "assets")
    assert "Development — ground truth public:</b> public ran on public worlds" in html


# --- a leaderboard that re-scores ----------------------------------------------------------------------------------
def test_the_leaderboard_rescores_every_entry_and_refuses_a_mismatch(tmp_path, monkeypatch):
    """Real run directories (results files scored by OMQ): an intact one is re-scored, matches and is ranked as
    before; one with an edited "OMQ" in scores.json, or in episode_scores.json, or a results file gone, is listed as
    'scores do not match its results' and never ranked; one on held-out worlds whose key this host lacks is listed as
    'not re-scored' and ranked on its recorded scores."""
    from benchbot.batch.leaderboard import MISMATCH
    from benchbot.core.registry import get_registry

    monkeypatch.setenv("BENCHBOT_WORLDS_KEY_FILE", str(tmp_path / "no-such.key"))  # this host holds no test key
    reg = get_registry()
    envs = {"miniroom:1": [0.8], "miniroom:2": [0.6]}
    paths = {"intact": make_run(tmp_path, "a", envs, example="intact"),
             "worse": make_run(tmp_path, "b", {e: [0.4] for e in envs}, example="worse"),
             "combined": make_run(tmp_path, "c", {e: [0.3] for e in envs}, example="combined"),
             "episode": make_run(tmp_path, "d", {e: [0.3] for e in envs}, example="episode"),
             "gone": make_run(tmp_path, "e", {e: [0.3] for e in envs}, example="gone")}
    scores = paths["combined"] / "scores.json"
    text = scores.read_text()
    assert len(re.findall(r'"OMQ": [0-9.e-]+', text)) == 1
    scores.write_text(re.sub(r'"OMQ": [0-9.e-]+', '"OMQ": 0.95', text))  # an adversary's edit
    episodes = paths["episode"] / "episode_scores.json"
    episodes.write_text(re.sub(r'"OMQ": [0-9.e-]+', '"OMQ": 0.95', episodes.read_text(), count=1))
    next((paths["gone"] / "results").iterdir()).unlink()
    runs = [load_run(p) for p in paths.values()]
    assign_labels(runs, None)
    before = {e["label"]: e["rank"] for e in entries(runs[:2])[report_runs.TASK][0]["entries"]}
    [(task, [table])] = entries(runs, ground_truth=reg).items()
    got = {e["label"]: (e["rescored"], e["rank"]) for e in table["entries"]}
    assert got == {"intact": ("matches", 1), "worse": ("matches", 2), "combined": ("differs", None),
                   "episode": ("differs", None), "gone": ("differs", None)}
    assert before == {"intact": 1, "worse": 2}  # intact entries: ranked as before
    reasons = {e["label"]: e["rescore_reason"] for e in table["entries"]}
    assert reasons["intact"] == "re-scored: 2 results files give its scores"
    assert reasons["combined"].startswith(f"{MISMATCH}: scores.json: scores.OMQ 0.95 recorded, ")
    assert reasons["episode"].startswith(f"{MISMATCH}: episode_scores.json, episode 0: OMQ 0.95 recorded, ")
    assert "is not in the run directory" in reasons["gone"]
    # an entry whose ground truth this host lacks: not re-scored (said), ranked on its recorded scores
    held = [load_run(scores_only_run(tmp_path, "f", {"procedural_test_7:1": [0.5]}, example="held"))]
    assign_labels(held, None)
    [[row]] = [t["entries"] for t in entries(held, ground_truth=reg)[report_runs.TASK]]
    assert (row["rescored"], row["rank"]) == ("not re-scored", 1)
    assert row["rescore_reason"] == ("not re-scored: this host lacks the ground truth of procedural_test_7:1 "
                                     "(held-out worlds: only their host builds them)")
    write_site(runs + held, tmp_path / "site", reports=False, ground_truth=reg)
    page = (tmp_path / "site" / f"{slug(task)}.html").read_text()
    assert f"combined ({MISMATCH})" in page and "listed, never ranked" in page
    assert "1 entry is <b>not re-scored</b>: this host lacks the ground truth of procedural_test_7:1" in page
    data = json.loads((tmp_path / "site" / "leaderboard.json").read_text())
    assert {e["label"]: e["rescored"] for t in data["tasks"][task] for e in t["entries"]}["held"] == "not re-scored"


def test_a_signed_entry_whose_scores_differ_from_its_results_is_not_ranked_with_the_verified(tmp_path, monkeypatch):
    """Re-scoring refuses a mismatch whatever signs it: on held-out worlds whose key this host holds, a run whose
    host signed scores its results do not give (a host's bug, or an evaluation changed since) is listed in the
    verified table, not ranked; the intact one is re-scored and ranked; through the CLI, one line names the refused."""
    from benchbot.batch.signing import sign_run, write_key_pair
    from benchbot_worlds.procedural import splits

    monkeypatch.setenv("BENCHBOT_WORLDS_KEY_FILE", str(tmp_path / "worlds" / "test_split.key"))
    splits.make_key()
    host, host_pub = write_key_pair(tmp_path / "host")
    intact = make_run(tmp_path, "a", {"procedural_test_0:1": [0.7]}, example="intact")
    wrong = make_run(tmp_path, "b", {"procedural_test_0:1": [0.2]}, example="wrong")
    scores = wrong / "scores.json"
    scores.write_text(re.sub(r'"OMQ": [0-9.e-]+', '"OMQ": 0.9', scores.read_text()))
    for run in (intact, wrong):
        manifest = json.loads((run / "manifest.json").read_text())
        manifest["finished"] = "2026-11-26T00:00:00+00:00"
        (run / "manifest.json").write_text(json.dumps(manifest))
        sign_run(run, host)  # signed after the edit: the signature holds, the re-score does not
    proc = benchbot("leaderboard", str(intact), str(wrong), "-o", str(tmp_path / "site"), "--no-reports",
                    "--trusted-key", str(host_pub))
    assert proc.returncode == 0, proc.stderr
    [line] = [x for x in proc.stderr.splitlines() if x.startswith("not ranked")]
    assert line.startswith(f"not ranked wrong ({wrong}): scores do not match its results: scores.json: scores.OMQ 0.9 "
                           "recorded, 0.")
    data = json.loads((tmp_path / "site" / "leaderboard.json").read_text())
    [table] = data["tasks"][report_runs.TASK]
    assert table["standing"] == "verified"
    assert {e["label"]: (e["status"], e["rescored"], e["rank"]) for e in table["entries"]} == {
        "intact": ("verified", "matches", 1), "wrong": ("verified", "differs", None)}


def test_the_batch_says_whether_its_worlds_are_public(tmp_path):
    """`benchbot batch`'s manifest records its worlds' standing, and its closing line says it: development — ground
    truth public on BEAR and procedural train/val, held-out worlds on a held-out split."""
    from types import SimpleNamespace

    from benchbot.batch.plan import plan_episodes
    from benchbot.batch.runner import prepare_batch
    from benchbot.batch.signing import DEVELOPMENT, HELD_OUT
    from benchbot.cli.batch_cmd import batch_summary
    from benchbot.core.registry import get_registry

    specs = plan_episodes(task=report_runs.TASK, robots=["carter"], envs=["miniroom:1"], repeat=1, seed=0,
                          argv=["true"], cwd=str(tmp_path), options={}, timeout_s=None)
    prepare_batch(get_registry(), run_dir=tmp_path, specs=specs, evaluate_with=None, prefix="batch", zip_results=False)
    assert json.loads((tmp_path / "manifest.json").read_text())["worlds"] == DEVELOPMENT
    public = SimpleNamespace(episodes=[SimpleNamespace(status="ok", env="miniroom:1"),
                                       SimpleNamespace(status="ok", env="procedural_test_0:1")], evaluation=None)
    held = SimpleNamespace(episodes=[SimpleNamespace(status="ok", env="procedural_test_0:1")], evaluation=None)
    assert batch_summary(public, 3.0).endswith(f"; {DEVELOPMENT}")
    assert batch_summary(held, 3.0).endswith("; held-out worlds") and HELD_OUT == "held-out"
