"""benchbot report --predictivity: sim-vs-real numbers on constructed runs whose answer is known, the pairing of
the two halves, the refusals, and the page with its files."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from benchbot.batch import predictivity as pred
from benchbot.batch import stats
from benchbot.batch.run_data import assign_labels, load_run
from benchbot.core.errors import UsageError

sys.path.insert(0, str(Path(__file__).parent))
from report_runs import scores_only_run  # noqa: E402

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]
ENVS = [f"miniroom:{v}" for v in range(1, 6)]


def cli(*args):
    return subprocess.run([*BENCHBOT, *args], capture_output=True, text=True, timeout=300)


def test_across_environments_reproduces_the_constructed_answer(tmp_path):
    # per-environment means: sim 1..5 (as 0.1..0.5), real swaps neighbours 1<->2 and 3<->4: Spearman 0.8,
    # Pearson 0.8, MMRV (0.1 * 4 + 0) / 5 = 0.08
    sim = {e: [0.1 * (k + 1) - 0.01, 0.1 * (k + 1) + 0.01] for k, e in enumerate(ENVS)}
    real_means = [0.2, 0.1, 0.4, 0.3, 0.5]
    real = {e: [m] for e, m in zip(ENVS, real_means)}
    s, r = load_run(scores_only_run(tmp_path, "sim", sim)), load_run(scores_only_run(tmp_path, "real", real))
    result = pred.analyse([s], [r], "auto")
    assert result["across"] == "environments" and result["units"] == ENVS
    assert result["sim"] == pytest.approx([0.1, 0.2, 0.3, 0.4, 0.5]) and result["real"] == pytest.approx(real_means)
    st = result["statistics"]
    assert st["spearman"]["value"] == pytest.approx(0.8) and st["pearson"]["value"] == pytest.approx(0.8)
    assert st["mmrv"]["value"] == pytest.approx(0.08)
    assert st["pearson"]["low"] is not None and st["spearman"]["p"] == pytest.approx(0.1040880, abs=1e-6)
    assert result["episodes"][0] == (2, 1)


def test_across_solutions_pairs_the_halves_in_order(tmp_path):
    # three solutions; each one's performance is the mean over environments of its environment means
    sims = [scores_only_run(tmp_path, f"sim{k}", {"miniroom:1": [0.1 * k], "miniroom:2": [0.1 * k + 0.2]},
                            example=f"solution{k}") for k in range(1, 4)]
    reals = [scores_only_run(tmp_path, f"real{k}", {"miniroom:1": [v], "miniroom:2": [v]}, example=f"solution{k}")
             for k, v in zip(range(1, 4), (0.3, 0.1, 0.5))]
    runs = [load_run(p) for p in sims + reals]
    sim, real = pred.split_halves(runs)
    assign_labels(sim, None)  # labelled per setting, as the command does: a solution has one name in each
    assign_labels(real, None)
    result = pred.analyse(sim, real)
    assert result["across"] == "solutions" and result["units"] == ["solution1", "solution2", "solution3"]
    assert result["sim"] == pytest.approx([0.2, 0.3, 0.4]) and result["real"] == pytest.approx([0.3, 0.1, 0.5])
    st = result["statistics"]
    assert st["spearman"]["value"] == pytest.approx(0.5)  # ranks (1,2,3) vs (2,1,3): 1 - 6*2/24
    assert st["spearman"]["low"] is None and "n = 3 < 5" in st["spearman"]["reason"]
    # MMRV by hand: unit 1 vs 2 swapped (real gap 0.2) -> 0.2 for both, unit 3 none -> 0.4 / 3
    assert st["mmrv"]["value"] == pytest.approx(0.4 / 3)
    assert result["notes"] == []


def test_pairing_problems_are_reported(tmp_path):
    a = load_run(scores_only_run(tmp_path, "a", {"miniroom:1": [0.2], "house:1": [0.1]}))
    b = load_run(scores_only_run(tmp_path, "b", {"miniroom:1": [0.3]}, example="other"))
    result = pred.analyse([a], [b], "environments")
    assert result["units"] == ["miniroom:1"]
    assert any("ran different solutions" in n for n in result["notes"])
    assert any("house:1 covered by one setting only" in n for n in result["notes"])
    assert result["statistics"]["spearman"]["value"] is None
    with pytest.raises(UsageError, match="needs at least 2 pairs"):
        pred.analyse([a], [b], "solutions")
    with pytest.raises(UsageError, match="even number"):
        pred.split_halves([a, b, a])
    c = load_run(scores_only_run(tmp_path, "c", {"house:2": [0.3]}))
    with pytest.raises(UsageError, match="share no environment"):
        pred.analyse([a], [c], "environments")


@pytest.mark.slow
def test_cli_predictivity_page_and_errors(tmp_path):
    sim = scores_only_run(tmp_path, "sim", {e: [0.1 * (k + 1)] for k, e in enumerate(ENVS)})
    real = scores_only_run(tmp_path, "real", {e: [m] for e, m in zip(ENVS, [0.2, 0.1, 0.4, 0.3, 0.5])})
    out = tmp_path / "p" / "predictivity.html"
    proc = cli("report", "--predictivity", str(sim), str(real), "--settings", "primitives,furnished", "-o", str(out))
    assert proc.returncode == 0, proc.stderr
    assert "Spearman ρ = 0.8 [" in proc.stdout and "MMRV = 0.08 [" in proc.stdout
    page = out.read_text()
    assert "Does primitives predict furnished?" in page and "Kadian et al. 2020" in page and "Li et al. 2024" in page
    files = out.parent / "predictivity_files"
    for stem in ("scatter.png", "scatter.svg", "scatter.pdf", "predictivity.csv", "predictivity.tex", "units.csv",
                 "predictivity.json"):
        assert (files / stem).is_file(), stem
    assert json.loads((files / "predictivity.json").read_text())["statistics"]["n"] == 5
    proc = cli("report", "--predictivity", str(sim), str(real), str(sim))
    assert proc.returncode == 2 and "even number of run directories" in proc.stderr and "Traceback" not in proc.stderr
    proc = cli("report", "--predictivity", str(sim), str(real), "--across", "robots")
    assert proc.returncode == 2 and "--across: 'robots' is not one of" in proc.stderr
    proc = cli("report", "--predictivity", str(sim), str(real), "--settings", "sim")
    assert proc.returncode == 2 and "--settings: 'sim' is not two names" in proc.stderr
    assert stats.MIN_CORRELATION_N == 5
