"""The procedural generator as the registry uses it: homes made on first use into the cache (five files, written
once), environment specs of type world naming their home's files, ground truths by name, homes made in parallel
before a batch (byte-identical to those made one by one), and a content pack that `benchbot install` validates."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from benchbot.core.registry import Registry


@pytest.fixture
def cache(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("BENCHBOT_CACHE_DIR", str(folder))
    return folder


def test_a_home_is_made_on_first_use_and_found_by_name(cache):
    reg = Registry()
    envs = reg.scenes("procedural:val:5:1:2")
    assert [e["name"] for e in envs] == ["procedural_val_5"] * 2 and [e["type"] for e in envs] == ["world"] * 2
    files = envs[0]["home_files"]
    assert len(files) == 5 and all(Path(f).is_relative_to(cache) for f in files) and envs[0]["map_path"] == files[0]
    assert envs[1]["lighting"] == "day" and envs[0]["lighting"] == "base"
    gt = reg.ground_truth("procedural_val_5:2")
    assert gt["environment"]["name"] == "procedural_val_5" and gt["ground_truth"]["objects"]
    stamps = [os.stat(f).st_mtime_ns for f in files]
    Registry().scenes("procedural_val_5:3")  # a second process finds the files: not made again
    assert [os.stat(f).st_mtime_ns for f in files] == stamps


@pytest.mark.slow
def test_homes_made_in_parallel_equal_those_made_one_by_one(cache, tmp_path, monkeypatch):
    reg = Registry()
    assert reg.make_generated(["procedural:val:11", "procedural_val_12:1", "procedural:val:13:1:2", "miniroom:1"],
                              workers=2) == 3
    parallel = {f: Path(f).read_bytes() for e in ("11", "12", "13") for f in reg.scenes(f"procedural_val_{e}:1")[0]
                ["home_files"]}
    monkeypatch.setenv("BENCHBOT_CACHE_DIR", str(tmp_path / "serial"))
    serial = [Path(f).read_bytes() for e in ("11", "12", "13") for f in Registry().scenes(f"procedural_val_{e}:1")[0]
              ["home_files"]]
    assert list(parallel.values()) == serial


@pytest.mark.slow
def test_a_generated_pack_installs_and_its_batch_names_its_homes(cache, tmp_path):
    pack = tmp_path / "procedural_val_2"
    env = {**os.environ, "BENCHBOT_DATA_DIR": str(tmp_path / "data")}
    run = [str(Path(sys.executable).parent / "benchbot")]
    made = subprocess.run([*run, "worlds", "generate", "--split", "val", "--count", "2", "-o", str(pack)],
                          capture_output=True, text=True, env=env, timeout=300)
    assert made.returncode == 0, made.stderr
    assert sorted(p.name for p in (pack / "environments").iterdir())[:2] == ["procedural_val_0_1.yaml",
                                                                             "procedural_val_0_2.yaml"]
    assert len(list((pack / "ground_truths").iterdir())) == 10
    again = subprocess.run([*run, "worlds", "generate", "--count", "2", "-o", str(pack)], capture_output=True,
                           text=True, env=env, timeout=300)
    assert again.returncode == 2 and again.stderr.count("\n") <= 2 and "exists" in again.stderr
    installed = subprocess.run([*run, "install", str(pack)], capture_output=True, text=True, env=env, timeout=300)
    assert installed.returncode == 0, installed.stderr
    listed = subprocess.run([*run, "list", "batches", "--json"], capture_output=True, text=True, env=env, timeout=300)
    batch = next(b for b in json.loads(listed.stdout) if b["name"] == "procedural_val_2")
    assert batch["plugin"] == "content_packs"


@pytest.mark.parametrize("args, message", [
    (["--split", "dev"], "--split 'dev' is no split of procedural homes"),
    (["--count", "0"], "--count 0 is less than 1"),
    (["--count", "10001"], "--count 10001 is more than the maximum of 10000"),
    (["--start", "-1"], "--start -1 is less than 0"),
])
def test_bad_requests_are_one_line(tmp_path, args, message):
    from typer.testing import CliRunner

    from benchbot_worlds.cli import app

    result = CliRunner().invoke(app, ["generate", *args, "-o", str(tmp_path / "p")])
    assert result.exit_code == 2 and message in result.output, result.output
    assert not (tmp_path / "p").exists()
