"""Runs ``test_sim_conventions.py`` in a fresh Python process and fails when any of its tests fails (their output
is shown). In the process of a full test run its DDS listeners heard nothing from the bridge; on its own it passes."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest


@pytest.mark.slow
def test_ros2_conventions_in_a_fresh_process():
    module = Path(__file__).with_name("test_sim_conventions.py")
    env = {**os.environ, "BENCHBOT_ROS2_CONVENTIONS_CHILD": "1"}
    proc = subprocess.run([sys.executable, "-m", "pytest", str(module), "-q", "-p", "no:cacheprovider"],
                          capture_output=True, text=True, env=env, timeout=900)
    assert proc.returncode == 0 and " passed" in proc.stdout and "skipped" not in proc.stdout.splitlines()[-1], \
        proc.stdout[-4000:] + proc.stderr[-2000:]
