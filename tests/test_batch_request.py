"""benchbot.batch.request: what ``benchbot batch`` was asked, checked in one line per mistake and planned before any
backend starts; a run directory only for a batch that was planned. Nothing runs here."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from benchbot.batch.plan import read_manifest
from benchbot.batch.request import BatchRequest, new_batch, resume_batch
from benchbot.core.errors import SpecError, UsageError
from benchbot.core.registry import get_registry


def request(tmp_path: Path, **changes) -> BatchRequest:
    """A native ``true`` on miniroom:1 and miniroom:2, unsandboxed, into ``tmp_path/runs``, with ``changes``."""
    base = BatchRequest(task="semantic_slam:passive:ground_truth", robot="carter", robots=None,
                        envs="miniroom:1,miniroom:2", envs_batch=None, native="true", example=None, containerised=None,
                        example_containerised=False, args="", repeat=2, seed=5, timeout_s=None, record=False,
                        noise=None, sweep=None, backend_options=lambda: {"arch": "cpu"}, no_sandbox=True, workers=1,
                        prefix="batch", output_dir=tmp_path / "runs", zip_results=False, evaluate_with="auto",
                        ground_truths=None)
    return dataclasses.replace(base, **changes)


@pytest.mark.parametrize("changes, message", [
    ({"native": None}, "give exactly one of --native COMMAND, --example NAME and --containerised DIR"),
    ({"example": "semslam_geometric"}, "give exactly one of --native COMMAND, --example NAME and --containerised DIR"),
    ({"example_containerised": True}, "--example-containerised needs --example NAME"),
    ({"prefix": "../escape"}, "--prefix '../escape' is not a name"),
    ({"noise": "low", "sweep": "noise=none,low"}, "--noise and --sweep noise=... both set the noise"),
    ({"robots": "carter", "sweep": "robot=carter,carter_ros2"}, "--robots and --sweep robot=... both set the robots"),
])
def test_a_wrong_flag_is_one_line_and_leaves_no_run_directory(tmp_path, changes, message):
    with pytest.raises(UsageError) as info:
        new_batch(get_registry(), request(tmp_path, **changes), say=print)
    assert info.value.message == message
    assert not (tmp_path / "runs").exists()


def test_a_planned_batch_has_its_run_directory_and_one_that_cannot_be_prepared_leaves_none(tmp_path):
    said: list[str] = []
    batch = new_batch(get_registry(), request(tmp_path), say=said.append)
    assert batch.run_dir.parent == (tmp_path / "runs").resolve() and batch.run_dir.name.startswith("batch-")
    assert [(s.env, s.repeat, s.seed, s.sandbox, s.argv) for s in batch.specs] == [
        ("miniroom:1", 0, 5, "none", ["true"]), ("miniroom:1", 1, 6, "none", ["true"]),
        ("miniroom:2", 0, 7, "none", ["true"]), ("miniroom:2", 1, 8, "none", ["true"])]
    assert read_manifest(batch.run_dir)["evaluate_with"] == "omq" and said == []
    assert resume_batch(get_registry(), batch.run_dir, no_sandbox=True).run_dir == batch.run_dir
    with pytest.raises(SpecError, match="no evaluator named 'nope'"):
        new_batch(get_registry(), request(tmp_path / "other", evaluate_with="nope"), say=print)
    assert list((tmp_path / "other" / "runs").iterdir()) == []  # made, then removed: nothing ran


def test_an_unwritable_output_folder_is_one_line(tmp_path):
    (tmp_path / "file").write_text("")
    with pytest.raises(UsageError) as info:
        new_batch(get_registry(), request(tmp_path, output_dir=tmp_path / "file" / "runs"), say=print)
    assert info.value.message.startswith(f"--output-dir: cannot write {tmp_path / 'file' / 'runs'} (")
    assert info.value.hint == "choose a writable path"


def test_a_noise_sweep_plans_every_level(tmp_path):
    batch = new_batch(get_registry(), request(tmp_path, sweep="noise=none,high", repeat=1), say=print)
    assert [(s.env, s.noise) for s in batch.specs] == [("miniroom:1", "none"), ("miniroom:2", "none"),
                                                       ("miniroom:1", "high"), ("miniroom:2", "high")]
    assert read_manifest(batch.run_dir)["sweep"]["levels"] == ["none", "high"]
