"""Fixtures of the robot_ros2 tests: DDS confined to loopback, a test-specific ROS domain, a fake ROS 2 robot and
the simulator served over ROS 2 in a subprocess (Taichi is one thread per process)."""

from __future__ import annotations

import gc
import os
import subprocess
import sys
from pathlib import Path

import pytest

from benchbot_robot_ros2.transport import LOOPBACK_URI

sys.path.insert(0, str(Path(__file__).parent))
from dds_domains import claim_domain_block  # noqa: E402

os.environ.setdefault("CYCLONEDDS_URI", LOOPBACK_URI)


@pytest.fixture(scope="session")
def domain_id() -> int:
    """The first DDS domain of this test run's block (:func:`dds_domains.claim_domain_block`); tests add offsets
    below ``dds_domains.DOMAIN_BLOCK``."""
    base, lock = claim_domain_block()
    yield base
    lock.close()


@pytest.fixture(autouse=True)
def _earlier_dds_entities_collected_here():
    """Collect the cyclic garbage of earlier tests (DDS readers, writers, participants they dropped) on the test's
    own thread before it starts, and its own after it ends. Left to the garbage collector's whim, such an entity
    could be deleted (``Entity.__del__``, a ``dds_delete``) inside a listener callback of another thread, while the
    test's teardown removes that listener: Cyclone DDS then waits on both sides and the run hangs (seen once in the
    fast loop: a fake robot's ``DataWriter.write`` delivering to a local reader, ``close`` in ``set_listener``)."""
    gc.collect()
    yield
    gc.collect()


@pytest.fixture()
def transport(domain_id):
    from benchbot_robot_ros2.transport import CycloneTransport

    tr = CycloneTransport(domain_id, "loopback")
    yield tr
    tr.close()


#: Simulated seconds per wall second of the shared bridge and of the controller that drives it. The controller is a
#: wall-clock loop: a stall of a loaded 2-core machine moves the robot ``stall · speed · scale`` past its goal (at 4×,
#: 3.8 cm in one CI run), so the comparisons with the direct simulation run at 2×.
BRIDGE_TIME_SCALE = 2


@pytest.fixture(scope="module")
def sim_bridge(domain_id):
    """``benchbot_robot_ros2.sim_bridge`` serving miniroom (64×48 camera, :data:`BRIDGE_TIME_SCALE` × real time) in a
    subprocess, on ``domain_id + 1``; yields ``(domain id, time scale)``."""
    dom = domain_id + 1
    env = dict(os.environ, ROS_DOMAIN_ID=str(dom), CYCLONEDDS_URI=os.environ["CYCLONEDDS_URI"])
    log = open(Path(os.environ.get("TMPDIR", "/tmp")) / f"benchbot_bridge_{dom}.log", "w")
    proc = subprocess.Popen([sys.executable, "-m", "benchbot_robot_ros2.sim_bridge", "--env", "miniroom:4",
                             "--camera-size", "64x48", "--time-scale", str(BRIDGE_TIME_SCALE), "--transport",
                             "cyclonedds"],
                            env=env, stdout=log, stderr=subprocess.STDOUT)
    yield dom, BRIDGE_TIME_SCALE
    proc.terminate()
    try:
        proc.wait(10)
    except subprocess.TimeoutExpired:
        proc.kill()
    log.close()
