"""The manifest's provenance: git revisions of BenchBot and the solution, and the machine (no host name)."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

from benchbot.batch import provenance
from benchbot.batch.plan import plan_episodes
from benchbot.batch.runner import prepare_batch
from benchbot.core.registry import get_registry

ROOT = Path(__file__).resolve().parents[1]


def test_git_revision_of_a_work_tree_and_of_a_plain_folder(tmp_path):
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()
    revision = provenance.git_revision(ROOT / "benchbot")
    assert revision is not None and revision.split("+")[0] == head
    assert provenance.git_revision(tmp_path) is None


def test_git_revision_marks_a_dirty_work_tree(tmp_path):
    def git(*args):
        subprocess.run(["git", "-C", str(tmp_path), "-c", "user.name=t", "-c", "user.email=t@t", *args],
                       check=True, capture_output=True)

    git("init", "-q")
    (tmp_path / "f.txt").write_text("a")
    git("add", "f.txt")
    git("commit", "-q", "-m", "one")
    clean = provenance.git_revision(tmp_path)
    assert clean is not None and len(clean) == 40
    (tmp_path / "f.txt").write_text("b")
    assert provenance.git_revision(tmp_path) == clean + "+dirty"


def test_machine_names_no_host():
    info = provenance.machine()
    assert set(info) == {"system", "architecture", "cpu", "cpus", "memory_gib"}  # no host name: manifests get published


def test_prepare_batch_records_provenance(tmp_path):
    specs = plan_episodes(task="semantic_slam:passive:ground_truth", robots=["carter"], envs=["miniroom:1"],
                          repeat=1, seed=0, argv=["true"], cwd=str(tmp_path), options={}, timeout_s=None)
    manifest = prepare_batch(get_registry(), run_dir=tmp_path, specs=specs, evaluate_with=None, prefix="batch",
                             zip_results=False).manifest
    written = json.loads((tmp_path / "manifest.json").read_text())
    assert written["provenance"] == manifest["provenance"]
    assert written["provenance"]["solution_git"] == {"$RUN_DIR": None}  # no absolute path: the run directory
    assert written["provenance"]["benchbot_git"]
    assert written["provenance"]["machine"]["cpus"] >= 1


def test_the_command_is_shell_quoted_and_the_lock_and_versions_recorded(tmp_path):
    import hashlib
    import importlib.metadata as md

    assert provenance.command_line(["/home/x/.venv/bin/benchbot", "batch", "--native", "python my.py --fast",
                                    "--envs", "miniroom:1"]) == \
        "benchbot batch --native 'python my.py --fast' --envs miniroom:1"
    lock = provenance.lock_hash(ROOT)
    assert lock["sha256"] == hashlib.sha256((ROOT / "uv.lock").read_bytes()).hexdigest()
    assert provenance.lock_hash(tmp_path) is None  # an installed BenchBot has no lock file
    packages = provenance.packages()
    assert packages["numpy"] == md.version("numpy") and packages["scipy"] == md.version("scipy")


def test_an_episode_records_its_backend(registry):
    from benchbot.core.session import resolve_run

    run = resolve_run(registry, "semantic_slam:passive:ground_truth", "carter", "miniroom:1")
    facts = provenance.backend_facts(registry, run.robot, run.environments)
    assert facts["type"] == "sim_taichi" and facts["plugin"] == "sim_taichi"
    assert facts["distribution"] == "benchbot-sim-taichi" and facts["version"]
    assert facts["style"] == "primitives"  # the test run's BENCHBOT_SIM_STYLE (conftest.py); no scene names one
    assert facts["settings"]["BENCHBOT_SIM_STYLE"] == "primitives"
    furnished = [dict(e, style="furnished") for e in run.environments]
    assert provenance.backend_facts(registry, run.robot, furnished)["style"] == "furnished"


def test_manifest_paths_are_portable_and_made_local_again(tmp_path, monkeypatch):
    """Manifests name no absolute path: under the home folder ``~/...``, elsewhere relative to the run directory
    (``$RUN_DIR/...``); ``--resume`` makes them local again; ``BENCHBOT_MANIFEST_LOCAL=1`` keeps them."""
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    run_dir = tmp_path / "runs" / "batch-1"
    plan = [{"cwd": str(tmp_path / "home" / "sol"), "argv": ["/usr/bin/python3", "my.py", "--fast"],
             "container": None}]
    portable = provenance.portable_plan(plan, run_dir)
    assert portable == [{"cwd": "~/sol", "argv": ["$RUN_DIR/" + os.path.relpath("/usr/bin/python3", run_dir),
                                                  "my.py", "--fast"], "container": None}]
    assert provenance.local_plan({"plan": portable}, run_dir)["plan"] == plan
    assert provenance.portable_command(["/x/.venv/bin/benchbot", "batch", "--output-dir", str(tmp_path / "home" / "r")],
                                       run_dir) == ["benchbot", "batch", "--output-dir", "~/r"]
    monkeypatch.setenv("BENCHBOT_MANIFEST_LOCAL", "1")
    assert provenance.portable_plan(plan, run_dir) == plan and provenance.local_node()["hostname"]


def test_a_ray_node_is_named_by_its_id_and_by_its_address_only_where_recorded():
    """Manifests name no host by default: a Ray node's record is ``{id}``, and error lines name it by its id's start."""
    from benchbot.batch.executors import node_name

    assert node_name({"id": "3f2a1b2c99aa"}) == "3f2a1b2c"
    assert node_name({"id": "3f2a1b2c99aa", "address": "10.0.0.7"}) == "10.0.0.7 (3f2a1b2c)"
    assert node_name({}) == "an unknown node"


def test_packages_read_name_and_version_as_importlib_metadata_does():
    """The manifest's ``packages`` read each distribution's header alone (``provenance.metadata_fields``): the same
    names and versions as ``dist.metadata`` / ``dist.version`` give, for every installed distribution and for
    headers with continuation lines, other cases, repeated fields, a field after a line that ends the header."""
    import importlib.metadata as md
    from email import message_from_string

    expected = {}
    for dist in md.distributions():
        name = (dist.metadata["Name"] or "").lower()
        if name:
            expected[name] = dist.version
    assert provenance.packages() == dict(sorted(expected.items()))
    texts = [
        "Metadata-Version: 2.1\nname: Foo-Bar\nVERSION: 1.0\n\nName: not-this\n",
        "Name: a\n  continued\nVersion:\t2.0 \nName: second\n",
        "Summary: x\nNot a field line\nName: after-the-header\nVersion: 3\n",
        "From someone\nName: b\nVersion: 4\n",
        "Version: 5\n",
        "Name: c\r\n  d\r\nVersion: 6\r\n\r\n",
        "",
    ]
    for text in texts:
        message = message_from_string(text)
        want = {k: message[k] for k in ("name", "version") if message[k] is not None}
        assert provenance.metadata_fields(text, ("name", "version")) == want, text
