"""`benchbot challenge init` / `evaluate` (benchbot/batch/challenge.py, docs/challenge.md): the host's keys, the test
split's key, conditions.json; a submission run sandboxed through `benchbot batch` and signed; one-line errors."""

from __future__ import annotations

import json
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from benchbot.batch import challenge, signing
from benchbot.core.errors import UsageError

sys.path.insert(0, str(Path(__file__).parent))
from cli_in_process import benchbot  # noqa: E402

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]
EXAMPLES = Path(__file__).resolve().parents[1] / "benchbot" / "plugins" / "examples"


def cli(*args, env=None, timeout=300):
    import os

    return subprocess.run([*BENCHBOT, *args], capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, **(env or {})})


@pytest.fixture
def worlds_key(tmp_path, monkeypatch):
    path = tmp_path / "worlds" / "test_split.key"
    monkeypatch.setenv("BENCHBOT_WORLDS_KEY_FILE", str(path))
    return path


def test_init_on_the_test_split_makes_the_keys_and_public_conditions(tmp_path, worlds_key):
    cond = challenge.init_challenge(tmp_path / "ch", task="semantic_slam:passive:ground_truth", robot="carter",
                                    split="test", count=3)
    private, public = tmp_path / "ch" / signing.PRIVATE_KEY_FILE, tmp_path / "ch" / signing.PUBLIC_KEY_FILE
    assert stat.S_IMODE(private.stat().st_mode) == 0o600 and stat.S_IMODE(worlds_key.stat().st_mode) == 0o600
    assert cond["environments"] == ["procedural_test_0:1", "procedural_test_1:1", "procedural_test_2:1"]
    assert cond["worlds"] == signing.HELD_OUT and cond["isolation"] == "bwrap"
    assert cond["fingerprint"] == signing.fingerprint(signing.load_public_key(public))
    written = json.loads((tmp_path / "ch" / "conditions.json").read_text())
    assert written == cond and len(cond["test_split_key_id"]) == 12
    assert worlds_key.read_text().strip() not in json.dumps(written)  # the key's id is public, the key is not
    # the worlds key is kept (a new one would change every test home); a second challenge in the folder is refused
    key = worlds_key.read_bytes()
    challenge.init_challenge(tmp_path / "ch2", task="t", robot="r", split="test", count=1)
    assert worlds_key.read_bytes() == key
    with pytest.raises(UsageError, match="already holds a challenge"):
        challenge.init_challenge(tmp_path / "ch", task="t", robot="r", split="test", count=1)


def test_the_challenge_sets_each_solutions_limits_and_refuses_a_run_under_others(tmp_path, monkeypatch):
    """conditions.json records the limits on each solution (this host's BENCHBOT_SANDBOX_* values, --limit on top);
    the batch gets them as those variables; a run whose manifest records other limits is not signed."""
    from benchbot.solutions.sandbox_limits import SandboxLimits

    monkeypatch.setenv("BENCHBOT_SANDBOX_PROCESSES", "300")
    cond = challenge.init_challenge(tmp_path / "ch", task="t", robot="r", split=None, count=1,
                                    environments=["miniroom:1"], limits=["memory=3G", "cpu=600"])
    solution = cond["limits"]["solution"]
    assert solution == {"memory_bytes": 3 << 30, "processes": 300, "file_bytes": SandboxLimits.current().file_bytes,
                        "cpu_s": 600, "tmp_bytes": SandboxLimits.current().tmp_bytes,
                        "outputs_bytes": SandboxLimits.current().outputs_bytes}
    env = challenge.batch_environment(cond)
    assert (env["BENCHBOT_SANDBOX_MEMORY_BYTES"], env["BENCHBOT_SANDBOX_CPU_S"]) == (str(3 << 30), "600")
    monkeypatch.setenv("BENCHBOT_SANDBOX_MEMORY_BYTES", env["BENCHBOT_SANDBOX_MEMORY_BYTES"])
    monkeypatch.setenv("BENCHBOT_SANDBOX_CPU_S", "600")
    run = tmp_path / "run"
    run.mkdir()
    manifest = {"task": "t", "robots": ["r"], "environments": ["miniroom:1"], "sandbox": "bwrap",
                "limits": SandboxLimits.current().record()}
    (run / "manifest.json").write_text(json.dumps(manifest))
    challenge.check_matches(run, cond)  # the run's solutions ran under the challenge's limits
    manifest["limits"]["memory_bytes"] = 8 << 30
    (run / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(UsageError, match="its solution limits .* is not the challenge's"):
        challenge.check_matches(run, cond)
    for bad, words in ((["speed=3"], "is not NAME=VALUE"), (["memory=lots"], "--limit memory='lots' is not a positive")):
        with pytest.raises(UsageError, match=words) as info:
            challenge.solution_limits(bad)
        assert "--limit" in info.value.hint


def test_init_without_benchbot_worlds_says_so_in_one_line(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "benchbot_worlds.procedural", None)  # as if it were not installed
    with pytest.raises(UsageError, match="needs benchbot-worlds, which is not installed") as info:
        challenge.init_challenge(tmp_path / "ch", task="t", robot="r", split="test", count=1)
    assert "pip install benchbot-worlds" in info.value.hint and not (tmp_path / "ch").exists()


def test_cli_bad_input_is_one_line(tmp_path):
    for args, words in ((("init", str(tmp_path / "a"), "--split", "exam"), "--split 'exam' is not a split"),
                        (("init", str(tmp_path / "a")), "give --split"),
                        (("init", str(tmp_path / "a"), "--task", "nope", "--split", "val"), "nope"),
                        (("init", str(tmp_path / "a"), "--split", "val", "--limit", "cpu=-1"), "--limit cpu='-1' is not"),
                        (("evaluate", str(tmp_path), "--challenge", str(tmp_path)), "conditions.json: missing")):
        proc = benchbot("challenge", *args)
        assert proc.returncode in (2, 3) and words in proc.stderr and "Traceback" not in proc.stderr, (args, proc.stderr)
    proc = benchbot("challenge", "init", str(tmp_path / "ch"), "--environments", "miniroom:1")
    assert proc.returncode == 0, proc.stderr
    (tmp_path / "empty").mkdir()
    proc = benchbot("challenge", "evaluate", str(tmp_path / "empty"), "--challenge", str(tmp_path / "ch"))
    assert proc.returncode == 2 and "0 top-level .py files" in proc.stderr and "--native" in proc.stderr
    proc = benchbot("challenge", "evaluate", str(tmp_path), "--challenge", str(tmp_path / "ch"), "--native",
                    "python x.py")
    assert proc.returncode == 2 and "is inside the submission folder" in proc.stderr
    (tmp_path / "ch" / "host_key.pem").write_text("garbled\n")
    proc = benchbot("challenge", "evaluate", str(tmp_path / "empty"), "--challenge", str(tmp_path / "ch"))
    assert proc.returncode == 2 and "host_key.pem: not a readable Ed25519 private key" in proc.stderr


@pytest.mark.slow
def test_evaluate_runs_the_submission_sandboxed_and_signs_it(tmp_path, worlds_key):
    """End to end on one episode of the held-out split (procedural_test_0:1, built with this test's worlds key; the
    hello_passive example as a participant's folder): the run is sandboxed, signed, verifies with the host's key,
    is ranked as verified on the leaderboard, and fails verification once a results byte is edited."""
    proc = cli("challenge", "init", str(tmp_path / "ch"), "--split", "test", "--count", "1", "--limit", "memory=3G")
    assert proc.returncode == 0, proc.stderr
    submission = tmp_path / "team"
    submission.mkdir()
    for name in ("hello_passive.py", "_example_io.py"):
        shutil.copy(EXAMPLES / name, submission / name)
    proc = cli("challenge", "evaluate", str(submission), "--challenge", str(tmp_path / "ch"), "--native",
               "python hello_passive.py", timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    [run] = list((tmp_path / "ch" / "runs").iterdir())
    assert proc.stdout.strip().endswith(f"signed: {run / 'signature.json'}")
    manifest = json.loads((run / "manifest.json").read_text())
    assert manifest["sandbox"] == "bwrap" and manifest["environments"] == ["procedural_test_0:1"]
    signed = json.loads((run / "signature.json").read_text())["signed"]
    assert signed["conditions"]["challenge"]["split"] == "test" and "conditions.json" in signed["files"]
    assert signed["conditions"]["worlds"] == signing.HELD_OUT
    assert signed["conditions"]["limits"]["solution"]["memory_bytes"] == manifest["limits"]["memory_bytes"] == 3 << 30
    assert any(f.startswith("results/") for f in signed["files"])
    public = tmp_path / "ch" / signing.PUBLIC_KEY_FILE
    proc = cli("verify", str(run), "--key", str(public))
    assert proc.returncode == 0 and proc.stdout.startswith("verified: "), proc.stderr
    site = tmp_path / "site"
    proc = cli("leaderboard", str(run), "-o", str(site), "--no-reports", "--trusted-key", str(public))
    assert proc.returncode == 0, proc.stderr
    [entry] = [e for t in json.loads((site / "leaderboard.json").read_text())["tasks"].values() for x in t
               for e in x["entries"]]
    assert entry["status"] == "verified" and entry["worlds"] == signing.HELD_OUT and entry["rank"] == 1
    [results] = list((run / "results").iterdir())
    data = bytearray(results.read_bytes())
    data[-2] ^= 0x01
    results.write_bytes(bytes(data))
    proc = cli("verify", str(run), "--key", str(public))
    assert proc.returncode == 1 and f"{results}: changed since it was signed" in proc.stderr


@pytest.mark.slow
def test_a_solution_carrying_public_ground_truth_scores_no_better_than_the_baseline_on_held_out_worlds(tmp_path,
                                                                                                      worlds_key):
    """The embedded-ground-truth adversary through `challenge evaluate` on the held-out split (procedural_test_0:1, this test's
    key): the solution that carries BEAR's public ground truth in its code (tests/embedded_gt_solution.py) has none
    for a test home and guesses another home's; it scores no better than semslam_geometric, the honest baseline
    (docs/challenge.md, "What an adversary gets": 2-core CPU, 3 homes, 0.0009 vs 0.1511). About 1 minute."""
    sys.path.insert(0, str(Path(__file__).parent))
    import embedded_gt_solution

    from benchbot.core.registry import get_registry

    proc = cli("challenge", "init", str(tmp_path / "ch"), "--split", "test", "--count", "1")
    assert proc.returncode == 0, proc.stderr
    cheat = embedded_gt_solution.write_submission(tmp_path / "cheat")
    example = get_registry().entry("examples", "semslam_geometric")  # as `benchbot batch --example` runs it
    omq = {}
    for name, folder, command in (("cheat", cheat.parent, f"python {cheat.name}"),
                                  ("baseline", example.path.parent, example.spec["native_command"])):
        proc = cli("challenge", "evaluate", str(folder), "--challenge", str(tmp_path / "ch"), "--native", command,
                   timeout=600)
        assert proc.returncode == 0, proc.stderr[-3000:]
        run = Path(proc.stdout.strip().splitlines()[-1].removeprefix("signed: ")).parent
        assert json.loads((run / "manifest.json").read_text())["worlds"] == signing.HELD_OUT
        assert "; held-out worlds" in proc.stderr
        omq[name] = json.loads((run / "scores.json").read_text())["scores"]["OMQ"]
        if name == "cheat":
            [log] = (run / "logs").iterdir()
            assert "GUESSED house:1 for procedural_test_0:1" in log.read_text()  # it ran, it carried, it guessed
    assert omq["cheat"] <= omq["baseline"], omq
    assert omq["baseline"] > 0.05, omq  # the baseline found something: the comparison means something
