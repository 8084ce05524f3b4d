"""``benchmarks/sweep.py``'s check that every run wrote the same bytes: per file digests, and which files differ."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

import sweep  # noqa: E402


def _run_dir(root: Path, results: dict[str, bytes]) -> Path:
    """A run directory with the given results files, one trajectory and scores.json."""
    (root / "results").mkdir(parents=True)
    (root / "trajectories").mkdir()
    for name, data in results.items():
        (root / "results" / name).write_bytes(data)
    (root / "trajectories" / "000_house_1_r0.json").write_bytes(b"[]")
    (root / "scores.json").write_bytes(b"{}")
    (root / "log.txt").write_bytes(root.name.encode())  # not a result: differs between runs, never compared
    return root


def test_runs_with_the_same_results_have_one_digest_and_no_differing_files(tmp_path):
    runs = [sweep.file_digests(_run_dir(tmp_path / k, {"000_house_1_r0.json": b'{"objects": []}'})) for k in "ab"]
    assert sorted(runs[0]) == ["results/000_house_1_r0.json", "scores.json", "trajectories/000_house_1_r0.json"]
    assert sweep.digest(runs[0]) == sweep.digest(runs[1])
    assert sweep.differing_files([{"files": f} for f in runs]) == []


def test_a_changed_or_missing_results_file_is_named(tmp_path):
    a = sweep.file_digests(_run_dir(tmp_path / "a", {"000_house_1_r0.json": b"1", "001_house_1_r1.json": b"2"}))
    b = sweep.file_digests(_run_dir(tmp_path / "b", {"000_house_1_r0.json": b"1", "001_house_1_r1.json": b"3"}))
    c = sweep.file_digests(_run_dir(tmp_path / "c", {"000_house_1_r0.json": b"1"}))
    assert sweep.digest(a) != sweep.digest(b)
    assert sweep.differing_files([{"files": a}, {"files": b}]) == ["results/001_house_1_r1.json"]
    assert sweep.differing_files([{"files": a}, {"files": a}, {"files": c}]) == ["results/001_house_1_r1.json"]


def test_episodes_of_one_environment_that_wrote_different_results_are_counted(tmp_path):
    a = sweep.file_digests(_run_dir(tmp_path / "a", {"000_house_1_r0.json": b"1", "001_house_1_r1.json": b"1",
                                                     "002_miniroom_3_r0.json": b"x", "003_miniroom_3_r1.json": b"y"}))
    b = sweep.file_digests(_run_dir(tmp_path / "b", {"000_house_1_r0.json": b"1", "001_house_1_r1.json": b"1",
                                                     "002_miniroom_3_r0.json": b"x", "003_miniroom_3_r1.json": b"x"}))
    c = sweep.file_digests(_run_dir(tmp_path / "c", {"000_miniroom_1.json": b"1"}))  # one repeat: no _r suffix
    assert sweep.results_per_environment([{"files": a}, {"files": b}, {"files": c}]) == {
        "house_1": 1, "miniroom_1": 1, "miniroom_3": 2}
