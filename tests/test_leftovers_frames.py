"""A killed backend's frames folder (/dev/shm/benchbot-frames-*, benchbot.protocol.shared_frames.episode_folder) is
removed by the next batch's clean-up (benchbot.solutions.leftovers.clean_leftovers), never a live backend's, nor one
without an owner file."""
from __future__ import annotations

import os
import secrets
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from benchbot.protocol import shared_frames
from benchbot.solutions.leftovers import clean_leftovers

pytestmark = pytest.mark.skipif(not shared_frames.available(), reason="no writable /dev/shm on this machine")

#: A backend's side of an episode served on a Unix socket: its frames folder, then a segment no client mapped.
BACKEND = """
import sys, time
import numpy as np
from benchbot.protocol import shared_frames
pool = shared_frames.SegmentPool()
pool.serve_socket(sys.argv[1])
pool.pack({"image_rgb": np.zeros((256, 256, 3), np.uint8)}, ("0" * 32, None, 0), True)
print(pool.socket_folder, flush=True)
time.sleep(600)
"""


def _backend(socket: Path) -> tuple[subprocess.Popen, Path]:
    process = subprocess.Popen([sys.executable, "-c", BACKEND, str(socket)], stdout=subprocess.PIPE, text=True)
    return process, Path(process.stdout.readline().strip())


def test_a_killed_backends_frames_folder_is_removed_and_a_live_ones_kept(tmp_path):
    (killed, killed_folder), (live, live_folder) = _backend(tmp_path / "a.sock"), _backend(tmp_path / "b.sock")
    no_owner = Path(shared_frames.SHM_DIR) / f"benchbot-frames-{secrets.token_hex(16)}"
    no_owner.mkdir(0o700)  # an older BenchBot's, or one being made: never judged
    try:
        assert killed_folder == Path(shared_frames.episode_folder(tmp_path / "a.sock"))
        assert len(os.listdir(killed_folder)) == 1  # the segment its client never mapped
        killed.send_signal(signal.SIGKILL)
        killed.wait()
        assert killed_folder.is_dir() and Path(shared_frames.owner_file(str(killed_folder))).is_file()
        removed = clean_leftovers(tmp_path / "no-temporary-folders", shm=shared_frames.SHM_DIR)
        assert killed_folder in removed and live_folder not in removed and no_owner not in removed
        assert not killed_folder.exists() and not os.path.lexists(shared_frames.owner_file(str(killed_folder)))
        assert live_folder.is_dir() and len(os.listdir(live_folder)) == 1
        assert Path(shared_frames.owner_file(str(live_folder))).is_file() and no_owner.is_dir()
    finally:
        for process in (killed, live):
            process.kill()
            process.wait()
        no_owner.rmdir()
    assert live_folder in clean_leftovers(tmp_path / "no-temporary-folders", shm=shared_frames.SHM_DIR)


def test_a_folder_in_use_is_never_taken_over_and_a_closed_one_leaves_nothing(tmp_path):
    """A second backend for the same socket path finds the first one's folder in use (its owner lives): its clients
    stay inline, the first one's folder is untouched; closing the first removes its folder and owner file."""
    first, second = shared_frames.SegmentPool(), shared_frames.SegmentPool()
    first.serve_socket(tmp_path / "backend.sock")
    folder = first.socket_folder
    try:
        with pytest.raises(OSError, match="in use by a live backend"):
            shared_frames.make_episode_folder(folder)
        second.serve_socket(tmp_path / "backend.sock")
        assert second.socket_folder is None and first.socket_folder == folder and os.path.isdir(folder)
        assert Path(folder) not in clean_leftovers(tmp_path / "none", shm=shared_frames.SHM_DIR)
    finally:
        first.close()
    assert not os.path.lexists(folder) and not os.path.lexists(shared_frames.owner_file(folder))
