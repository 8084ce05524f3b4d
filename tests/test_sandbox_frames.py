"""A sandboxed solution's frames through shared memory: the backend writes them into the episode's folder on /dev/shm
(benchbot.protocol.shared_frames.episode_folder), bound read-only into that episode's sandbox only."""
from __future__ import annotations

import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

import pytest

from benchbot.core.errors import UsageError
from benchbot.protocol import shared_frames
from benchbot.server import build_app
from benchbot.server.server_thread import ServerThread

pytestmark = pytest.mark.skipif(not shared_frames.available(), reason="no writable /dev/shm on this machine")

ACTIVE = "semantic_slam:active:ground_truth"
#: Large enough that the images pass shared_frames.MIN_BYTES.
CAMERA = {"width": 256, "height": 192}

PROBE = r'''
import errno, json, mmap, os, sys
from benchbot.api.benchbot import HttpTransport

folder = os.environ.get("BENCHBOT_SHARED_MEMORY_DIR")
report = {"folder": folder, "switch": os.environ.get("BENCHBOT_SHARED_MEMORY")}
transport = HttpTransport(os.environ["BENCHBOT_SUPERVISOR_ADDRESS"])
transport.step(None, {}, None)  # the handshake: inline, and the segment to map
report["listed"] = sorted(os.listdir(folder))
observations = transport.step("move_angle", {"angle": 15.0}, None)["observations"]
report["zero_copy"] = isinstance(observations["image_rgb"].base, mmap.mmap)
report["shared"], report["error"] = transport.shared_memory, transport.shared_memory_error
for name in ["mine", *report["listed"]]:
    try:
        with open(os.path.join(folder, name), "w") as f:
            f.write("x")
        report.setdefault("written", []).append(name)
    except OSError as exc:
        report.setdefault("refused", []).append(errno.errorcode[exc.errno])
report["other_episode"] = [os.path.exists(sys.argv[1]), os.path.exists(os.path.join("/run/benchbot", "frames2"))]
report["dev_shm"] = sorted(n for n in os.listdir("/dev/shm") if n.startswith("benchbot"))
transport.close()
print(json.dumps(report))
'''


@pytest.fixture
def sandboxable():
    from benchbot.solutions.sandbox import check_available

    try:
        check_available()
    except UsageError as exc:
        pytest.skip(exc.message)


@pytest.mark.slow
def test_a_sandboxed_solution_reads_its_frames_from_its_own_read_only_folder(sandboxable, make_service, registry,
                                                                              tmp_path):
    """The frames arrive through the episode's folder (zero copy, the backend's counter of bytes made there), the
    solution cannot write into it and does not see another episode's folder; the folder goes with the server."""
    from benchbot.solutions.sandbox import INSIDE_FRAMES, inside_address, run_sandboxed

    private = Path(tempfile.mkdtemp(prefix="benchbot-test-frames-"))
    sock, other_sock = private / "backend.sock", private / "other.sock"
    server = ServerThread(build_app(make_service(ACTIVE, "miniroom:1", **CAMERA)), unix_socket=sock).start()
    other = ServerThread(build_app(make_service(ACTIVE, "miniroom:1", **CAMERA)), unix_socket=other_sock).start()
    folder, other_folder = shared_frames.episode_folder(sock), shared_frames.episode_folder(other_sock)
    try:
        assert shared_frames.is_private_folder(folder) and os.stat(folder).st_mode & 0o777 == 0o700
        assert shared_frames.is_private_folder(other_folder)
        solution = tmp_path / "solution"
        solution.mkdir()
        (solution / "probe.py").write_text(PROBE)
        outputs = tmp_path / "outputs"
        outputs.mkdir()
        log = tmp_path / "probe.log"
        with open(log, "w") as out:
            run = run_sandboxed([sys.executable, "probe.py", other_folder], solution, registry=registry,
                                backend_socket=sock, address=inside_address(server.address)[0], outputs=outputs,
                                result_name="results.json", log=out, timeout_s=120)
        text = log.read_text()
        assert run.outcome.returncode == 0, text
        seen = json.loads(text.strip().splitlines()[-1])
        assert seen["folder"] == INSIDE_FRAMES and seen["switch"] is None
        assert len(seen["listed"]) == 1 and shared_frames.NAME_PATTERN.fullmatch(seen["listed"][0])
        assert seen["shared"] is True and seen["error"] is None and seen["zero_copy"] is True
        assert "written" not in seen and set(seen["refused"]) == {"EROFS"}, seen
        assert seen["other_episode"] == [False, False] and seen["dev_shm"] == []
        assert server.app.segments._socket_bytes > 0 and other.app.segments._socket_bytes == 0
        assert os.listdir(folder) == []  # mapped, so unlinked; nothing the solution wrote
    finally:
        server.stop()
        other.stop()
    assert not os.path.exists(folder) and not os.path.exists(other_folder)
    shutil.rmtree(private)


def test_a_folder_another_user_could_have_made_is_never_used(tmp_path, monkeypatch):
    """The episode's folder must be this user's, a real directory, mode 0700: else segments stay inline."""
    monkeypatch.setattr(shared_frames, "SHM_DIR", str(tmp_path))
    path = shared_frames.episode_folder(tmp_path / "backend.sock")
    os.mkdir(path, 0o755)
    assert not shared_frames.is_private_folder(path)
    with pytest.raises(OSError):
        shared_frames.make_episode_folder(path)
    os.rmdir(path)
    os.symlink(tmp_path, path)
    assert not shared_frames.is_private_folder(path)
    pool = shared_frames.SegmentPool()
    pool.serve_socket(tmp_path / "backend.sock")
    assert pool.socket_folder is None
    os.unlink(path)
    pool.serve_socket(tmp_path / "backend.sock")
    assert pool.socket_folder == path and shared_frames.is_private_folder(path)
    pool.close()
    assert not os.path.exists(path)


def test_an_episodes_folder_holds_a_bounded_number_of_bytes(tmp_path):
    """Past EPISODE_SEGMENT_BYTES made in the episode's folder, its clients' replies go inline with a reason."""
    import numpy as np

    from benchbot.protocol import wire

    pool = shared_frames.SegmentPool()
    pool.serve_socket(tmp_path / "backend.sock")
    try:
        reply = {"observations": {"image_rgb": np.zeros((480, 640, 3), np.uint8)}}
        answers = [wire.unpack(pool.pack(reply, (f"{k:032x}", None, 0), True)) for k in range(40)]
        made = [a for a in answers if "shm_segment" in a]
        assert 0 < len(made) < 40 and all("budget" in a["shm_error"] for a in answers[len(made):])
        assert pool._socket_bytes <= shared_frames.EPISODE_SEGMENT_BYTES
        assert len(os.listdir(pool.socket_folder)) <= shared_frames.EPISODE_SEGMENTS
    finally:
        pool.close()
