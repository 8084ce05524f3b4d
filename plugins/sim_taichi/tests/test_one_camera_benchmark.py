"""``benchmarks/one_camera.py``: the launch probes run for real on the CPU (the GPU split needs CUDA, which the
test machines lack; the docs quote its H200 runs)."""

import inspect
import json
import subprocess
import sys
from pathlib import Path

import taichi as ti

from benchbot_sim_taichi.render.sensors import sensors_kernels

ROOT = Path(__file__).resolve().parents[3]
SCRIPT = [sys.executable, str(ROOT / "benchmarks" / "one_camera.py")]


def _ndarray_parameters(kernel) -> int:
    """Parameters of a Taichi kernel annotated as ndarrays, read from its signature."""
    return sum(isinstance(p.annotation, ti.types.ndarray_type.NdarrayType)
               for p in inspect.signature(kernel).parameters.values())


def test_the_launch_probes_time_graph_runs_and_count_the_frames_arguments():
    proc = subprocess.run(SCRIPT + ["--arch", "cpu", "--launch-only", "--bursts", "2", "--json"], capture_output=True,
                          text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    out = json.loads(proc.stdout)
    launch = out["launch"]
    for key in ("two_ndarrays_us", "thirty_ndarrays_us", "two_dispatches_us", "eight_tasks_us"):
        assert launch[key] > 0
    assert launch["per_ndarray_us"] == (launch["thirty_ndarrays_us"] - launch["two_ndarrays_us"]) / 28
    assert launch["per_dispatch_us"] == launch["two_dispatches_us"] - launch["two_ndarrays_us"]
    kernels = sensors_kernels("cpu")
    assert out["frame_launch"]["dispatches"] == len(kernels) == 4
    assert out["frame_launch"]["ndarray_args"] == sum(_ndarray_parameters(k) for k in kernels)
    assert "fps" not in out and "gpu_us_per_frame" not in out  # no GPU split on the CPU


def test_bad_flags_and_an_unknown_environment_are_refused_in_one_line():
    bad = subprocess.run(SCRIPT + ["--bursts", "0"], capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert bad.returncode == 2 and "must be at least 1" in bad.stderr and "Traceback" not in bad.stderr
    env = subprocess.run(SCRIPT + ["--env", "nowhere:9", "--arch", "cpu"], capture_output=True, text=True,
                         timeout=300, cwd=ROOT)
    assert env.returncode == 2 and "unknown environment nowhere:9" in env.stderr and "Traceback" not in env.stderr
