"""Long work says what it is doing (benchbot.core.stages): the simulator's stages reach listeners, commands show them
and say one "ready" line, and a stage's listener can never break the work."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from benchbot.core import stages

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]


def test_listeners_hear_every_stage_and_cannot_break_the_work(monkeypatch):
    monkeypatch.setattr(stages, "ADVANCE_INTERVAL_S", 0.0)
    heard = []

    def broken(event):
        raise RuntimeError("a listener's own bug")

    with stages.listening(heard.append), stages.listening(broken):
        with stages.stage("baking light", detail="12 points", total=3) as progress:
            for _ in range(3):
                progress.advance()
    assert [(e.kind, e.done) for e in heard] == [("start", 0), ("advance", 1), ("advance", 2), ("advance", 3),
                                                 ("end", 3)]
    assert heard[2].text() == "baking light (12 points, 2/3)"
    with stages.stage("unheard"):
        pass
    assert len(heard) == 5  # the listener is gone after its block


def test_a_thread_listener_hears_only_the_work_of_its_thread():
    """listening_here: two pieces of work on two threads each hear their own stages; a process-wide listener both."""
    import threading

    heard: dict[str, list[str]] = {"a": [], "b": [], "all": []}
    ready = threading.Barrier(2)

    def work(name: str) -> None:
        with stages.listening_here(lambda e: heard[name].append(f"{e.kind} {e.name}")):
            ready.wait(5)
            with stages.stage(f"building {name}"):
                pass
            ready.wait(5)  # both stages are told while both listeners are there

    with stages.listening(lambda e: heard["all"].append(e.name)):
        threads = [threading.Thread(target=work, args=(n,)) for n in ("a", "b")]
        for t in threads:
            t.start()
        for t in threads:
            t.join(10)
    with stages.stage("after"):  # the thread listeners are gone with their blocks
        pass
    assert heard["a"] == ["start building a", "end building a"]
    assert heard["b"] == ["start building b", "end building b"]
    assert sorted(heard["all"]) == ["building a"] * 2 + ["building b"] * 2


def read_until(proc: subprocess.Popen, marker: str, within_s: float) -> list[str]:
    lines, deadline = [], time.monotonic() + within_s
    while time.monotonic() < deadline:
        line = proc.stderr.readline()
        if not line:
            break
        lines.append(line.rstrip("\n"))
        if marker in line:
            return lines
    raise AssertionError(f"no {marker!r} within {within_s} s: {lines}")


@pytest.mark.slow
def test_run_says_each_stage_then_ready_in_a_log(tmp_path):
    """In a log (no terminal) each stage of the simulator's start is a line, then one "backend ready" line."""
    env = dict(os.environ, BENCHBOT_CACHE_DIR=str(tmp_path / "cache"))  # a cold scene
    proc = subprocess.Popen([*BENCHBOT, "run", "--env", "miniroom:1", "--port", "0", "--camera-size", "64x48",
                             "--no-tui"], stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True, env=env)
    try:
        lines = read_until(proc, "backend ready", 300)
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(60)
    started = [line for line in lines if line.endswith(" …")]
    assert started[:2] == ["building the scene (miniroom:1) …", "starting Taichi (cpu) …"], lines
    assert "building the BVH …" in started
    assert ("compiling kernels (once per machine, then cached) …" in started  # what happens, by Taichi's cache
            or "loading cached kernels (compiled on an earlier run) …" in started), lines
    assert lines[-1].startswith("backend ready at http://127.0.0.1:")
    assert proc.returncode == 130


@pytest.mark.slow
def test_ros2_serve_sim_is_ready_then_ends_on_ctrl_c_with_130(tmp_path):
    pytest.importorskip("cyclonedds")
    env = dict(os.environ, ROS_DOMAIN_ID="77", BENCHBOT_CACHE_DIR=str(tmp_path / "cache"))
    proc = subprocess.Popen([*BENCHBOT, "ros2", "serve-sim", "--env", "miniroom:1", "--camera-size", "64x48",
                             "--transport", "cyclonedds", "--arch", "cpu"], stderr=subprocess.PIPE,
                            stdout=subprocess.DEVNULL, text=True, env=env)
    try:
        lines = read_until(proc, "ready: serving miniroom:1 as a ROS 2 robot", 300)
        assert "miniroom:1: building the scene (miniroom:1) …" in lines
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(60)
    assert proc.returncode == 130  # as `benchbot run` and `batch`: before, 0


def test_the_kernel_stage_says_compiling_then_loading_cached_kernels(tmp_path):
    from benchbot_sim_taichi.render import kernel_cache

    cache = tmp_path / "ticache"
    assert kernel_cache.kernels_state("k1", cache) == "cold" and kernel_cache.kernels_state("k1", None) == "off"
    kernel_cache.mark_ready("k1", "cold", cache)  # a run compiled: its marker
    assert kernel_cache.kernels_state("k1", cache) == "memory"  # the same process: warm
    kernel_cache._WARM.discard("k1")
    assert kernel_cache.kernels_state("k1", cache) == "cold"  # Taichi wrote nothing after it: the run died
    (cache / "T1.tic").write_text("x")
    (cache / "ticache.tcb").write_text("x")  # Taichi's index, written as the compiling process ends
    assert kernel_cache.kernels_state("k1", cache) == "disk"
    assert kernel_cache.STAGES["disk"][0] == "loading cached kernels"
    assert kernel_cache.kernels_state("k2", cache) == "cold"  # other sources, Taichi or arch


def test_the_kernels_key_follows_what_taichi_keys_its_kernels_by(monkeypatch):
    """The thread count Taichi holds (``cpu_max_num_threads``: a batch worker's share of the cores) and the quick
    compiles' setting are in Taichi's own kernel keys, so they are in the marker's key too."""
    import taichi as ti

    from benchbot_sim_taichi.render import kernel_cache
    from benchbot_sim_taichi.render.renderer import ensure_taichi

    ensure_taichi("cpu")
    real = ti.lang.impl.current_cfg

    def keys() -> set:
        found = set()
        for threads, quick in ((2, "1"), (1, "1"), (2, "0")):
            monkeypatch.setattr(ti.lang.impl, "current_cfg", lambda: type("Cfg", (), {"cpu_max_num_threads": threads}))
            monkeypatch.setenv("BENCHBOT_TAICHI_QUICK_COMPILE", quick)
            kernel_cache.kernels_key.cache_clear()
            found.add(kernel_cache.kernels_key("cpu", "fast"))
        return found

    try:
        assert len(keys()) == 3
    finally:
        monkeypatch.setattr(ti.lang.impl, "current_cfg", real)
        kernel_cache.kernels_key.cache_clear()
