"""The Textual views: the batch table and the live run view (Pilot tests and snapshots), and their writers."""

from __future__ import annotations

import asyncio
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from benchbot.api.benchbot import BenchBot
from benchbot.core import atomic
from benchbot.plugins.live_state import PREVIEW, STATE, LiveStateWriter
from benchbot.tui.batch_app import BatchApp, batch_rows, format_seconds
from benchbot.tui.run_app import RunApp, half_blocks

FROZEN = 1_700_000_100.0  # the frozen clock of the views: wall times in snapshots never change
BENCHBOT = [sys.executable, "-m", "benchbot.cli"]


async def settle(pilot, condition, timeout_s: float = 5.0) -> None:
    """Let the app run until ``condition()`` holds or ``timeout_s`` has passed (the views poll their files every
    0.05 s here; a fixed pause failed on a loaded machine). The caller asserts what it waited for."""
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout_s
    while not condition() and loop.time() < deadline:
        await pilot.pause(0.05)


def _record(index, env, status, steps=0, wall=0.0, repeat=0):
    return {"index": index, "env": env, "robot": "carter", "repeat": repeat, "seed": index, "status": status,
            "attempts": int(status != "pending"), "steps": steps, "collided": False, "wall_s": wall,
            "returncode": 0 if status == "ok" else None, "error": "", "results": f"results/{index:03d}.json",
            "log": f"logs/{index:03d}.log"}


def make_run_dir(path: Path, finished: bool = False) -> Path:
    """A fabricated run directory: 4 episodes (ok, failed, running, pending), scores for the first."""
    trajectory = [[1, 0, 0, 0, 0, 0, 0]] * 33
    atomic.write_json(path / "config.json", {
        "task": {"name": "semantic_slam:passive:ground_truth", "actions": ["move_next"]},
        "environments": {e: [{"name": e.split(":")[0], "variant": e.split(":")[1], "trajectory_poses": trajectory}]
                         for e in ("miniroom:1", "miniroom:4", "house:1")}})
    episodes = [_record(0, "miniroom:1", "ok", 33, 12.5), _record(1, "miniroom:4", "failed", 7, 3.25),
                _record(2, "house:1", "running" if not finished else "ok", 0 if not finished else 33, 0.0 if not finished else 75.0),
                _record(3, "miniroom:1", "pending" if not finished else "ok", 0 if not finished else 33, 0.0 if not finished else 11.0, repeat=1)]
    manifest = {"task": "semantic_slam:passive:ground_truth", "robots": ["carter"], "episodes": episodes,
                "environments": ["miniroom:1", "miniroom:4", "house:1"], "plan": [],
                "scores": {"method": "omq", "scores": [{"name": "OMQ", "primary": True, "direction": "higher"}]}}
    if finished:
        manifest.update(finished="2024-01-01T00:00:00+00:00", evaluation_error="")
        atomic.write_json(path / "episode_scores.json", [
            {"index": i, "env": e["env"], "robot": "carter", "repeat": e["repeat"], "seed": i,
             "scores": {"OMQ": 0.25 * (i + 1) - 0.0123}} for i, e in enumerate(episodes) if e["status"] == "ok"])
        atomic.write_json(path / "scores.json", {"scores": {"OMQ": 0.6543}})
    else:
        atomic.write_json(path / "progress.json", {"episodes": {
            "2": {"state": "running", "step": 17, "started": FROZEN - 65.0}}})
    atomic.write_json(path / "manifest.json", manifest)
    return path


def make_state_dir(path: Path) -> Path:
    """A fabricated live-state folder: a 24x32 gradient preview and 3 steps."""
    y, x = np.mgrid[0:24, 0:32]
    rgb = np.stack([x * 8, y * 10, np.full_like(x, 128)], axis=-1).astype(np.uint8)
    np.save(path / PREVIEW, rgb)
    atomic.write_json(path / STATE, {
        "task": "semantic_slam:passive:ground_truth", "robot": "carter", "environments": ["miniroom:4"],
        "step": 3, "rate_hz": 1.5,
        "state": {"is_collided": False, "is_dirty": True, "is_finished": False, "is_running": True,
                  "scene_number": 0, "scene_count": 1},
        "pose": [1.25, -0.5, 0.7854], "last_action": {"action": "move_next", "args": {}, "result": "SUCCESS"},
        "preview": PREVIEW, "log": ["episode started", "step 1", "step 2", "step 3"], "log_total": 4})
    return path


# --------------------------------------------------------------------------------------------- batch view
def test_batch_rows_read_manifest_progress_and_scores(tmp_path):
    summary, rows = batch_rows(make_run_dir(tmp_path), now=FROZEN)
    assert summary["episodes"] == 4 and not summary["finished"]
    assert rows[0] == (0, "miniroom:1", "carter", 0, "ok", "33/33", "0:12", "")
    assert rows[2][4:7] == ("running", "17/33", "1:05")
    assert rows[3][4:7] == ("pending", "0/33", "")
    assert format_seconds(3725) == "1:02:05"
    assert batch_rows(tmp_path / "nothing") == ({}, [])


def test_batch_app_follows_the_run_directory(tmp_path):
    asyncio.run(_test_batch_app_follows_the_run_directory(tmp_path))


async def _test_batch_app_follows_the_run_directory(tmp_path):
    run_dir = make_run_dir(tmp_path)
    app = BatchApp(run_dir, poll_s=0.05, clock=lambda: FROZEN)
    async with app.run_test() as pilot:
        table = app.query_one("DataTable")
        assert table.row_count == 4
        assert "running" in str(table.get_cell("2", "status"))
        make_run_dir(run_dir, finished=True)  # the batch writes its manifest; the view polls it
        # the watcher may see the new manifest one poll before the scores written just ahead of it: wait for both
        await settle(pilot, lambda: "ok" in str(table.get_cell("2", "status")) and table.get_cell("0", "score") != "")
        assert "ok" in str(table.get_cell("2", "status"))
        assert table.get_cell("0", "score") == "0.2377" and str(table.columns["score"].label) == "OMQ"
        await pilot.press("q")
    assert app.return_code == 0


def test_batch_app_exits_when_the_batch_ends(tmp_path):
    # The bound is on a real process (its exit), which the app cannot swallow as it could a cancelled coroutine.
    run_dir = make_run_dir(tmp_path, finished=True)
    code = ("import sys; from benchbot.tui.batch_app import BatchApp; "
            "app = BatchApp(sys.argv[1], poll_s=0.05, is_done=lambda: True, linger_s=0.05); "
            "app.run(headless=True, size=(100, 14)); sys.exit(app.return_code or 0)")
    proc = subprocess.run([sys.executable, "-c", code, str(run_dir)], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr


@pytest.mark.slow
def test_batch_app_keys_enter_opens_a_log_ctrl_c_interrupts(tmp_path):
    asyncio.run(_test_batch_app_keys(tmp_path))


async def _test_batch_app_keys(tmp_path):
    run_dir = make_run_dir(tmp_path)
    (run_dir / "logs").mkdir()
    (run_dir / "logs" / "001.log").write_text("loading detector\nTraceback: boom\n")
    app = BatchApp(run_dir, poll_s=0.05, clock=lambda: FROZEN)
    async with app.run_test(size=(100, 20)) as pilot:
        await pilot.pause(0.1)
        await pilot.press("down", "enter")  # episode 1's log

        def log_lines() -> list:
            found = app.screen.query("#episode-log")
            return list(found.first().lines) if found else []

        await settle(pilot, lambda: log_lines() == ["loading detector", "Traceback: boom"])
        assert log_lines() == ["loading detector", "Traceback: boom"]
        await pilot.press("escape")
        await pilot.pause(0.1)
        assert app.screen.query("#episodes")
        await pilot.press("ctrl+c")  # at once: no "press ctrl+q to quit" dialog
    assert app.interrupted and app.return_code == 130


def test_batch_app_columns_grow_to_their_final_values(tmp_path):
    asyncio.run(_test_columns_grow(tmp_path))


async def _test_columns_grow(tmp_path):
    run_dir = make_run_dir(tmp_path)  # pending episodes: short cells first
    app = BatchApp(run_dir, poll_s=0.05, clock=lambda: FROZEN)
    async with app.run_test(size=(120, 20)) as pilot:
        make_run_dir(run_dir, finished=True)
        manifest = json.loads((run_dir / "manifest.json").read_text())
        manifest["episodes"][3]["steps"] = 269
        atomic.write_json(run_dir / "manifest.json", manifest)
        table = app.query_one("DataTable")

        def widths() -> dict:
            return {str(c.key.value): c.get_render_width(table) - 2 * table.cell_padding
                    for c in table.columns.values()}

        await settle(pilot, lambda: widths()["score"] >= len("0.9877") and widths()["steps"] >= len("269/33"))
        assert widths()["score"] >= len("0.9877") and widths()["steps"] >= len("269/33")


def test_batch_snapshot_running(snap_compare, tmp_path):
    app = BatchApp(make_run_dir(tmp_path), poll_s=3600, clock=lambda: FROZEN)
    app.sub_title = "run"
    assert snap_compare(app, terminal_size=(100, 14))


def test_batch_snapshot_finished(snap_compare, tmp_path):
    assert snap_compare(BatchApp(make_run_dir(tmp_path, finished=True), poll_s=3600, clock=lambda: FROZEN),
                        terminal_size=(100, 14))


# --------------------------------------------------------------------------------------------- run view
def test_half_blocks_draw_two_pixel_rows_per_line():
    rgb = np.zeros((3, 4, 3), np.uint8)
    rgb[0] = 255
    text = half_blocks(rgb)
    assert text.plain == "▀▀▀▀\n▀▀▀▀"
    assert str(text.spans[0].style.color.triplet) == "#ffffff" or text.spans[0].style.color.triplet.red == 255
    assert len(half_blocks(np.zeros((48, 64, 3), np.uint8), width=16).plain.splitlines()) == 6


def test_run_snapshot(snap_compare, tmp_path):
    assert snap_compare(RunApp(make_state_dir(tmp_path), poll_s=3600, preview_width=32), terminal_size=(110, 20))


def test_run_app_appends_new_log_lines(tmp_path):
    asyncio.run(_test_run_app_appends_new_log_lines(tmp_path))


async def _test_run_app_appends_new_log_lines(tmp_path):
    state_dir = make_state_dir(tmp_path)
    app = RunApp(state_dir, poll_s=0.05)
    async with app.run_test() as pilot:
        log = app.query_one("Log")
        assert log.line_count == 4
        state = json.loads((state_dir / STATE).read_text())
        state.update(step=4, log=state["log"][1:] + ["step 4"], log_total=5)
        atomic.write_json(state_dir / STATE, state)
        await settle(pilot, lambda: log.line_count == 5 and "steps        4" in str(app.query_one("#status").render()))
        assert log.line_count == 5 and "steps        4" in str(app.query_one("#status").render())


def test_live_state_writer_follows_a_real_episode(make_service, registry, tmp_path):
    service = make_service("semantic_slam:passive:ground_truth", "miniroom:4")
    writer = LiveStateWriter(tmp_path, max_rate_hz=1000)
    service.call(writer.attach, service.episode)
    registry.plugin_manager.register(writer)
    try:
        bot = BenchBot(backend=service)
        bot.reset()
        for _ in range(3):
            bot.step("move_next")
        service.call(writer.refresh)  # what `benchbot run --tui` does every 0.5 s: picks up the last observation
    finally:
        registry.plugin_manager.unregister(writer)
    state = json.loads((tmp_path / STATE).read_text())
    assert state["step"] == 3 and state["last_action"]["result"] == "SUCCESS"
    assert state["environments"] == ["miniroom:4"] and len(state["pose"]) == 3
    preview = np.load(tmp_path / PREVIEW)
    assert preview.dtype == np.uint8 and preview.shape == (48, 64, 3)
    assert state["log_total"] == 4


# --------------------------------------------------------------------------------------------- CLI
@pytest.mark.slow
def test_tui_command_needs_a_run_directory(tmp_path):
    proc = subprocess.run([*BENCHBOT, "tui", str(tmp_path)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and "neither manifest.json nor state.json" in proc.stderr


@pytest.mark.slow
def test_batch_records_and_writes_progress_without_a_terminal(tmp_path):
    proc = subprocess.run([*BENCHBOT, "batch", "--example", "hello_passive", "--envs", "miniroom:4", "--record",
                           "--camera-size", "64x48", "--arch", "cpu", "--no-evaluate", "--output-dir", str(tmp_path)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    run_dir = next(tmp_path.iterdir())
    assert (run_dir / "recordings" / "000_miniroom_4.mcap").is_file()
    progress = json.loads((run_dir / "progress.json").read_text())
    assert progress["episodes"]["0"]["state"] == "ended" and progress["episodes"]["0"]["step"] == 33
    from benchbot.plugins.replay import Recording

    assert len(Recording(run_dir / "recordings" / "000_miniroom_4.mcap").steps) == 33


def test_progress_file_keeps_the_last_step_and_reads_back_whatever_is_there(tmp_path):
    from benchbot.batch.progress import ProgressFile, read_progress

    assert read_progress(tmp_path) == {}
    live = ProgressFile(tmp_path)
    live.event("start", 3, None)
    assert read_progress(tmp_path)["3"]["state"] == "running"
    for n in range(1, 50):
        live.event("step", 3, {"step": n})  # written at most 4 times a second
    live.event("end", 3, None)  # always written, with the last step
    assert {k: v for k, v in read_progress(tmp_path)["3"].items() if k != "started"} == {
        "state": "ended", "step": 49, "stage": ""}
    atomic.write_json(tmp_path / "progress.json", {"episodes": ["not", "a", "map"]})
    assert read_progress(tmp_path) == {}


def test_a_starting_episode_shows_what_its_backend_is_doing(tmp_path):
    """Before its first step an episode's steps cell says the backend's stage ("building the BVH …"), from the
    progress file (before: 0/33 for the ~30 s the scene took to build)."""
    from benchbot.batch.progress import ProgressFile

    run_dir = make_run_dir(tmp_path)
    live = ProgressFile(run_dir)
    live.event("start", 2, None)
    live.event("stage", 2, {"stage": "building the BVH"})
    assert batch_rows(run_dir, now=FROZEN)[1][2][5] == "building the BVH …"
    live.event("stage", 2, {"stage": ""})
    live.event("step", 2, {"step": 1})
    live.event("end", 2, None)
    assert read_progress_stage(run_dir) == ""
    assert batch_rows(run_dir, now=FROZEN)[1][2][5] == "0/33"  # the record's steps once ended (not ok yet)


def read_progress_stage(run_dir):
    from benchbot.batch.progress import read_progress

    return read_progress(run_dir)["2"]["stage"]


def test_batch_view_shows_what_it_can_of_files_of_the_wrong_shape(tmp_path):
    run_dir = make_run_dir(tmp_path, finished=True)
    atomic.write_json(run_dir / "config.json", ["not", "a", "config"])
    atomic.write_json(run_dir / "episode_scores.json", [{"index": 0, "OMQ": None}, "junk"])
    summary, rows = batch_rows(run_dir, now=FROZEN)
    assert summary["episodes"] == 4 and rows[0][5] == "33" and rows[0][7] == ""  # no expected steps, no OMQ
    atomic.write_json(run_dir / "manifest.json", {"episodes": [{"index": "x"}]})
    asyncio.run(_shows_a_one_line_problem(run_dir))


async def _shows_a_one_line_problem(run_dir):
    app = BatchApp(run_dir, poll_s=3600, clock=lambda: FROZEN)
    async with app.run_test() as pilot:
        await pilot.pause(0.1)
        assert "is not a batch manifest" in str(app.query_one("#summary").render())


def test_batch_view_fits_80_columns_with_a_long_stage(tmp_path):
    asyncio.run(_test_fits_80_columns(tmp_path))


async def _test_fits_80_columns(tmp_path):
    """At 80×24 a starting episode's stage is shortened (its detail first) so that every column, wall and score
    included, stays on the screen (before: the stage pushed them off)."""
    run_dir = make_run_dir(tmp_path)
    atomic.write_json(run_dir / "progress.json", {"episodes": {"2": {
        "state": "running", "step": 0, "started": FROZEN - 65.0,
        "stage": "loading the BVH, shadow maps and baked light (from the cache)"}}})
    app = BatchApp(run_dir, poll_s=0.05, clock=lambda: FROZEN)
    async with app.run_test(size=(80, 24)) as pilot:
        table = app.query_one("DataTable")
        await settle(pilot, lambda: "2" in table.rows and str(table.get_cell("2", "steps")).startswith("loading"))
        steps = str(table.get_cell("2", "steps"))
        assert steps.startswith("loading the BVH") and steps.endswith("…") and "(from the cache)" not in steps
        widths = [c.get_render_width(table) for c in table.columns.values()]
        assert sum(widths) <= 80 - 2, widths  # every column on screen, beside the scrollbar
        assert str(table.get_cell("2", "wall")) == "1:05"


def test_fit_drops_the_detail_then_cuts():
    from benchbot.tui.batch_app import fit

    assert fit("0/48", 10) == "0/48"
    assert fit("building the scene (miniroom:1) …", 24) == "building the scene …"
    assert fit("building the scene (miniroom:1) …", 12) == "building th…"


# --------------------------------------------------------------------------------------------- typed messages
def test_the_batch_view_draws_what_its_typed_messages_carry(tmp_path):
    """The view holds no file reading of its own: on a run directory with no files at all, the messages a watcher
    would post (manifest, config, progress) are enough to draw the running episode (before: the widgets re-read and
    compared the files every 0.5 s)."""
    asyncio.run(_draws_messages(tmp_path))


async def _draws_messages(tmp_path):
    from benchbot.tui.batch_app import ConfigChanged, ManifestChanged, ProgressChanged, read_expected

    source = make_run_dir(tmp_path / "source")
    empty = tmp_path / "empty"
    empty.mkdir()
    app = BatchApp(empty, poll_s=3600, clock=lambda: FROZEN)
    async with app.run_test() as pilot:
        assert "waiting for" in str(app.query_one("#summary").render())
        app.post_message(ManifestChanged(json.loads((source / "manifest.json").read_text())))
        app.post_message(ConfigChanged(read_expected(source / "config.json")))
        app.post_message(ProgressChanged({"2": {"state": "running", "step": 21, "started": FROZEN - 5.0}}))
        table = app.query_one("DataTable")
        await settle(pilot, lambda: "2" in table.rows and table.get_cell("2", "steps") == "21/33")
        assert table.get_cell("2", "steps") == "21/33" and table.get_cell("2", "wall") == "0:05"
    assert not any(empty.iterdir())


def test_the_watcher_reads_a_file_only_when_its_stat_changed(tmp_path):
    """Each check is a stat; a file is read (its message made) only when its size, time or inode changed: an
    atomic rewrite with the same bytes is a new inode, so it is seen; an idle directory is never read again."""
    from benchbot.tui.watch import FileWatcher, Watched

    reads = []
    path = tmp_path / "progress.json"

    def message(p):
        reads.append(p.read_text() if p.exists() else "missing")
        return reads[-1]  # stands for a message (FileWatcher only passes it on)

    watcher = FileWatcher(None, [Watched(path, message)], interval_s=3600)
    assert watcher.scan() == ["missing"]  # the first scan: every file, a missing one too
    assert watcher.scan() == [] and reads == ["missing"]
    atomic.write_json(path, {"episodes": {}})
    assert watcher.scan() == [path.read_text()]
    for _ in range(20):
        assert watcher.scan() == []
    atomic.write_json(path, {"episodes": {}})  # the same bytes, replaced: a new inode
    assert len(watcher.scan()) == 1 and len(reads) == 3


def test_an_idle_view_reads_no_file_after_its_first_frame(tmp_path):
    """A finished batch's view, checked every 0.05 s for half a second, reads each file once (its first frame)."""
    asyncio.run(_idle_reads(tmp_path))


async def _idle_reads(tmp_path):
    from benchbot.tui import batch_app

    run_dir = make_run_dir(tmp_path, finished=True)
    read = []
    original = batch_app.read_json
    batch_app.read_json = lambda path: read.append(path.name) or original(path)
    try:
        app = BatchApp(run_dir, poll_s=0.05, clock=lambda: FROZEN)
        async with app.run_test() as pilot:
            await pilot.pause(0.5)
            assert "0.9877" in str(app.query_one("DataTable").get_cell("3", "score"))
    finally:
        batch_app.read_json = original
    assert sorted(read) == ["config.json", "episode_scores.json", "manifest.json", "scores.json"], read
