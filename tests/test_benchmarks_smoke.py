"""Every script in ``benchmarks/`` runs: each one, found by globbing, as a real subprocess in its tiny smoke mode
(``--smoke``, ``benchmarks/smoke.py``: the smallest scene, images and counts), must exit 0, say that it is a smoke
run, print its figures as a real run does, and name what it left out (a GPU's part, a program ``uv sync`` does not
install). A new script without a smoke mode, or without an entry in :data:`FIGURES`, fails here, so none rots
unnoticed. Tests of what a script computes (its flags, its comparisons) live beside the code they measure.

All of it: ``uv run pytest tests/test_benchmarks_smoke.py --durations=0`` (slow: 2.5 minutes on a 2-core machine
whose Taichi kernel cache is warm, the longest ``hostile_inputs.py``, ``baked_light.py`` and ``batch.py`` at 10-30 s
each; a kernel variant that no earlier test compiled adds its compile time once, which the slow tests of the
simulator's benchmarks would pay otherwise).
"""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
BENCHMARKS = ROOT / "benchmarks"
#: Modules of ``benchmarks/`` that the scripts import, not scripts: imported below, and run through their scripts.
HELPERS = {"gpu_host.py": "one_camera.py", "realism_counting.py": "realism.py", "realism_detectors.py": "realism.py",
           "realism_real.py": "realism.py", "smoke.py": "render.py", "trajectory_views.py": "render.py"}
SCRIPTS = sorted(p.name for p in BENCHMARKS.glob("*.py") if p.name not in HELPERS)
#: Per script, what its printed figures look like: patterns its standard output must match (a smoke run prints what
#: a real run prints, at its tiny sizes).
FIGURES = {
    "api_step.py": [r"native_step_ms +\d", r"legacy_step_ms +\d", r"native_requests_per_step +1\b"],
    "api_step_stages.py": [r"step_ms +\d", r"total_ms +\d"],
    "baked_light.py": [r"PSNR [\d.]+ dB", r"; [1-9]\d* points"],  # the lattice was baked (a furnished home)
    "batch.py": [r" 1 worker\(s\): +[\d.]+ s", r" 2 worker\(s\): +[\d.]+ s.*\[local\]",
                 r" 2 worker\(s\): +[\d.]+ s.*\[batched\]", r"speed-up [\d.]+x \[batched\]"],
    "bvh_build.py": [r"soup +old +\d+ tris +[\d.]+ s", r"house1 +new +\d+ tris +[\d.]+ s"],
    "cpu_by_process.py": [r"CPU of the command and every process started meanwhile: [\d.]+ s in [\d.]+ s wall",
                          r"processes +at most +\d+ threads +benchbot\.cli"],
    "example_mapping.py": [r"merged as it is +[\d.]+ ms a frame", r"merged every 8 frames +[\d.]+ ms a frame",
                           r"merged np\.unique +[\d.]+ ms a frame", r"objects from the map \(as it is\) +[\d.]+ s",
                           r"equal bit for bit: yes"],
    "cold_start.py": [r"quick compiles: [\d.]+ s wall, [\d.]+ s CPU", r"occluders_kernel +compile +[\d.]+ s CPU",
                      r"quick compiles, kernels cached: [\d.]+ s wall"],
    "compile_time.py": [r"fast [\d.]+ s, quality [\d.]+ s"],
    "cpu_paths.py": [r"graph [\d.]+ fps, numpy [\d.]+ fps"],
    "denoise.py": [r"median_ms +[\d.]+"],
    "end_to_end.py": [r"trivial +inprocess +33 +[\d.]+ +[\d.]+", r"hello_passive +native +33 +[\d.]+"],
    "first_run.py": [r"cold +[\d.]+ s +\(scene built; ready after [\d.]+ s: .*building the scene",
                     r"warm 1 +[\d.]+ s +\(scene from the scene cache; ready after .*loading the scene"],
    "layout_checks.py": [r"200 objects x 50 poses \(\d+ bytes as JSON\): \d+ problem lines in [\d.]+ s"],
    "hostile_inputs.py": [r"50 MB body on move_next +413", r"eval zip bomb .+ +4 +[\d.]+", r"log truncated at"],
    "omq.py": [r"omq_ms +[\d.]+", r"same scores: yes"],
    "one_camera.py": [r"launch \(cpu\): [\d.]+ µs", r"\d+ ndarray arguments, \d+ dispatches"],
    "quality_vs_reference.py": [r"ours quality 1 spp +[\d.]+ +[\d.]+ +[\d.]+"],
    "realism.py": [r"fast [\d.]+ ms a frame, quality [\d.]+ ms"],
    "realism_compare.py": [r"recall: first [\d.]+%, second [\d.]+%; the first in the second's class mix [\d.]+%"],
    "render.py": [r"[\d.]+ fps \([\d.]+ ms/frame\)", r"embree [\d.]+ Mrays/s"],
    "render_fps.py": [r"miniroom:4 +[\d.]+ fps"],
    "render_gpu.py": [r'"fps": [\d.]+', r'"fps_textured": [\d.]+'],
    "render_meshes.py": [r"[\d.]+ fps textured, [\d.]+ fps untextured"],
    "render_quality.py": [r"[\d.]+ fps denoised, [\d.]+ fps"],
    "ros2_load.py": [r"motions +\d+", r"faults +\d+"],
    "ros2_safety.py": [r"stop_latency_median_s +[\d.]+"],
    "ros2_step.py": [r"ros2_observe_ms: [\d.]+", r"direct_observe_ms: [\d.]+"],
    "sensors_kernels.py": [r"[\d.]+ fps with a synchronisation", r"shade\w*_kernel +[\d.]+ ms/launch"],
    "shadow_maps.py": [r"[\d.]+ fps with maps, [\d.]+ with rays"],
    "run_warm_start.py": [r"in-process +[\d.]+ s to ready \([\d.]+-[\d.]+\), Ctrl-C to exit [\d.]+ s",
                          r"service +[\d.]+ s to ready \([\d.]+-[\d.]+\), Ctrl-C to exit [\d.]+ s"],
    "service_warm.py": [r"in-process +[\d.]+ s wall, +[\d.]+ s CPU",
                        r"service +[\d.]+ s wall, +[\d.]+ s CPU of the command, +[\d.]+ s of the service",
                        r"byte-identical: yes"],
    "sweep.py": [r" service: +[\d.]+ s wall, 2 episodes \(2 ok\), 96 frames", r"no-service: +[\d.]+ s wall",
                 r"solution per frame +[\d.]+ ms", r"byte-identical: yes",
                 r"every episode of an environment wrote the same results: yes"],
    "turned_homes.py": [r"miniroom:1, first 2 poses", r"mirror_y +OMQ [\d.]+",
                        r"largest OMQ gap between turns: [\d.]+"],
    "world_generation.py": [r"per home [\d.]+ s mean", r"distinct homes: 20 of 20; invalid: 0",
                            r"chi-square [\d.]+, p [\d.e-]+"],
    "vector_env.py": [r"batched +N=3 +[\d.]+ env-steps/s", r"sync +N=1 +[\d.]+ env-steps/s"],
}
#: Per script, what its smoke run leaves out (words of its ``smoke: left out ...`` line on stderr).
LEFT_OUT = {
    "cold_start.py": ["the empty kernel cache"],
    "compile_time.py": ["the empty kernel cache"],
    "first_run.py": ["the empty kernel cache"],
    "one_camera.py": ["host/GPU split"],
    "quality_vs_reference.py": ["the Cycles reference"],
    "realism.py": ["the detector", "the Cycles reference"],
    "render_gpu.py": ["the CUDA cases"],
}
#: Seconds a smoke run may take: a few, but a Taichi kernel that no earlier test compiled takes a minute or more.
TIMEOUT_S = 900


@pytest.mark.parametrize("script", SCRIPTS)
def test_the_script_runs_in_its_smoke_mode_and_prints_its_figures(script):
    assert script in FIGURES, f"benchmarks/{script}: add the patterns of its printed figures to FIGURES"
    proc = subprocess.run([sys.executable, str(BENCHMARKS / script), "--smoke"], capture_output=True, encoding="utf-8",
                          errors="replace",
                          timeout=TIMEOUT_S, cwd=ROOT, stdin=subprocess.DEVNULL)
    said = f"\n--- stdout:\n{proc.stdout[-3000:]}\n--- stderr:\n{proc.stderr[-3000:]}"
    assert proc.returncode == 0, f"exit {proc.returncode}{said}"
    assert f"smoke: a tiny run of {script}" in proc.stderr, f"no smoke mode (benchmarks/smoke.py){said}"
    for pattern in FIGURES[script]:
        assert re.search(pattern, proc.stdout), f"no figure matching {pattern!r}{said}"
    left_out = [line for line in proc.stderr.splitlines() if line.startswith("smoke: left out ")]
    for words in LEFT_OUT.get(script, []):
        assert any(words in line for line in left_out), f"it does not say it left out {words!r}{said}"
    assert len(left_out) == len(LEFT_OUT.get(script, [])), f"unexpected left-out lines: {left_out}"
    assert "Traceback" not in proc.stderr, said


def test_the_helper_modules_are_no_scripts_and_import():
    """``gpu_host.py``, ``realism_counting.py``, ``realism_detectors.py``, ``realism_real.py``, ``smoke.py`` and
    ``trajectory_views.py`` are modules the scripts import (each imported by a script smoke-run above), not scripts;
    they import in a fresh interpreter; the Blender script beside ``realism.py`` (run under bpy, which ``uv sync`` does
    not install) is valid Python."""
    for helper, user in HELPERS.items():
        source = (BENCHMARKS / helper).read_text(encoding="utf-8")
        assert "__main__" not in source, f"{helper} is a script: give it a smoke mode and take it out of HELPERS"
        assert re.search(rf"^\s*(import {helper[:-3]}\b|from {helper[:-3]} import)", (BENCHMARKS / user).read_text(
            encoding="utf-8"), re.M), f"{user} no longer imports {helper}"
    names = ", ".join(h[:-3] for h in sorted(HELPERS))
    proc = subprocess.run([sys.executable, "-c", f"import {names}"], capture_output=True, text=True, timeout=300,
                          cwd=BENCHMARKS)
    assert proc.returncode == 0, proc.stderr[-3000:]
    for path in sorted((BENCHMARKS / "realism").glob("*.py")):
        ast.parse(path.read_text(encoding="utf-8"), str(path))
