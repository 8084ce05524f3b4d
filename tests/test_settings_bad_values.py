"""Bad values of the settings added with Ray's GPU placement (BENCHBOT_RAY_GPUS_PER_EPISODE) and the sandbox's frames
folder (BENCHBOT_SHARED_MEMORY_DIR, and the switch BENCHBOT_SHARED_MEMORY beside it): each is one line naming the
variable and the fix (`benchbot doctor`, the Ray batch that reads it), or the client's documented fallback (frames in
the HTTP reply, said in one line on stderr); never a traceback."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
from typer.testing import CliRunner

from benchbot.api.benchbot import HttpTransport
from benchbot.batch import executors
from benchbot.core.errors import UsageError
from benchbot.protocol import shared_frames

RAY = "BENCHBOT_RAY_GPUS_PER_EPISODE"
FOLDER, SWITCH = shared_frames.ENV_FOLDER, shared_frames.ENV_SWITCH


@pytest.mark.parametrize("bad", ["abc", "-1", "0", "0.00001", "1.5", "nan", "inf", "1e400", "0x1"])
def test_a_bad_share_of_a_gpu_is_one_line_naming_the_variable_and_the_fix(monkeypatch, bad):
    monkeypatch.setenv(RAY, bad)
    with pytest.raises(UsageError) as caught:
        executors.ray_gpus_per_episode()
    assert caught.value.message == (f"{RAY}={bad!r} is not a share of a GPU: a number from 0.0001 to 1 (0.0625: 16 "
                                    "episodes per GPU), or a whole number of GPUs")
    assert caught.value.hint == f"set {RAY} to a valid value, or unset it for the default, 0.0625"


@pytest.mark.parametrize(("good", "share"), [("0.0001", 0.0001), (" 0.5 ", 0.5), ("1", 1.0), ("3", 3.0), ("", 0.0625)])
def test_a_share_ray_takes_is_read(monkeypatch, good, share):
    monkeypatch.setenv(RAY, good)
    assert executors.ray_gpus_per_episode() == share


def test_doctor_names_each_bad_value_in_one_line():
    from benchbot.cli.main import app

    env = {RAY: "0", FOLDER: "frames", SWITCH: "on"}
    result = CliRunner().invoke(app, ["doctor", "--no-render", "--json"], env=env)
    check = next(c for c in json.loads(result.stdout)["checks"] if c["name"] == "settings")
    assert check["ok"] is False
    for line in (f"{RAY}='0' is not a share of a GPU", f"{FOLDER}='frames' is not an absolute path (one starting "
                 "with /)", f"{SWITCH}='on' is not one of 0, 1"):
        assert line in check["detail"]
    assert "Traceback" not in result.output


def test_a_ray_batch_with_a_bad_share_stops_before_it_starts_in_one_line(tmp_path):
    """From the command line, as a user runs it: an error line and a hint, exit status 2, before any Ray starts (it
    came after a local Ray had started, seconds later, leaving a run directory)."""
    env = dict(os.environ, **{RAY: "abc"})
    env.pop("BENCHBOT_DEBUG", None)
    run = subprocess.run([sys.executable, "-m", "benchbot.cli", "batch", "--executor", "ray", "--example",
                          "hello_passive", "--envs", "miniroom:1", "--no-service", "--no-tui", "--output-dir",
                          str(tmp_path)], env=env, capture_output=True, text=True, timeout=120)
    assert run.returncode == 2, run.stderr
    assert f"{RAY}='abc' is not a share of a GPU" in run.stderr and "Traceback" not in run.stderr
    assert f"set {RAY} to a valid value" in run.stderr and "a local Ray started" not in run.stderr
    assert list(tmp_path.iterdir()) == []


def _unusable_folders(tmp_path) -> dict[str, str]:
    (tmp_path / "a_file").write_text("not a folder")
    return {"abc": "an absolute path", "-1": "an absolute path", str(tmp_path / "a_file"): "a folder this process "
            "can read", str(tmp_path / "missing"): "a folder this process can read"}


def test_a_client_given_no_usable_frames_folder_takes_frames_in_the_reply_and_says_so(tmp_path, monkeypatch, capsys):
    for folder, what in _unusable_folders(tmp_path).items():
        monkeypatch.setenv(FOLDER, folder)
        transport = HttpTransport("http://127.0.0.1:9/")
        line = (f"{FOLDER}={folder!r} is not {what}: frames come in the HTTP reply (unset it for /dev/shm, or name "
                "the folder where the backend makes this client's segments)")
        assert transport.shared_memory is False and transport.shared_memory_error == line
        assert capsys.readouterr().err == f"[benchbot] {line}\n"
        transport.close()


@pytest.mark.skipif(not os.path.isdir(shared_frames.SHM_DIR), reason="no /dev/shm here")
def test_a_client_given_a_bad_switch_takes_frames_in_the_reply_and_a_good_one_is_quiet(tmp_path, monkeypatch,
                                                                                        capsys):
    monkeypatch.setenv(SWITCH, "on")
    transport = HttpTransport("http://127.0.0.1:9/")
    assert transport.shared_memory is False and SWITCH + "='on' is not 0 or 1" in transport.shared_memory_error
    assert capsys.readouterr().err.count("\n") == 1
    transport.close()
    for value, shared in (("0", False), ("1", True)):
        monkeypatch.setenv(SWITCH, value)
        monkeypatch.setenv(FOLDER, str(tmp_path))  # a readable folder: the client looks there
        transport = HttpTransport("http://127.0.0.1:9/")
        assert transport.shared_memory is shared and capsys.readouterr().err == ""
        transport.close()


def test_gym_over_devices_reads_the_simulators_arch_through_its_reader(monkeypatch):
    """``make_vec(devices=...)`` without an ``arch`` option reads BENCHBOT_TAICHI_ARCH: a value the simulator's
    setting does not take is one line naming it (it was read as text, and 'abc' ran as a CPU arch)."""
    from benchbot.gym_devices import resolve_devices

    monkeypatch.setenv("BENCHBOT_TAICHI_ARCH", "abc")
    with pytest.raises(UsageError, match=r"^BENCHBOT_TAICHI_ARCH='abc' is not one of cpu, gpu, cuda$"):
        resolve_devices(["cpu", "cpu"], None)
    monkeypatch.setenv("BENCHBOT_TAICHI_ARCH", " CPU ")
    assert resolve_devices(["cpu", "cpu"], None) == ["cpu", "cpu"]


@pytest.mark.parametrize(("variable", "bad", "said"), [
    ("BENCHBOT_SERVICE", "abc", "BENCHBOT_SERVICE='abc' is not one of auto, off"),
    ("BENCHBOT_SERVICE_IDLE_S", "soon", "BENCHBOT_SERVICE_IDLE_S"),
])
def test_a_batch_with_a_bad_service_setting_stops_in_one_line_before_making_anything(tmp_path, variable, bad, said):
    """The service's settings are checked before the batch is planned: no run directory is made (it was, and
    `run directory:` printed, before the error)."""
    env = {**os.environ, "BENCHBOT_SERVICE": "auto", variable: bad}
    env.pop("BENCHBOT_DEBUG", None)
    run = subprocess.run([sys.executable, "-m", "benchbot.cli", "batch", "--example", "hello_passive", "--envs",
                          "miniroom:1", "--no-tui", "--output-dir", str(tmp_path)], env=env, capture_output=True,
                         text=True, timeout=120)
    assert run.returncode == 2, run.stderr
    assert said in run.stderr and "Traceback" not in run.stderr and "run directory" not in run.stderr, run.stderr
    assert list(tmp_path.iterdir()) == []
