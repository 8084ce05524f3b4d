"""A passive task's next observations rendered ahead while the client works (``RobotBackend.prefetch``,
``Episode.prefetch_next``, the native step's hint on the backend thread), on the real simulator: bit for bit what
the steps give without it, and a hint never taken changes nothing."""

from __future__ import annotations

import numpy as np

from benchbot.core.episode import Episode

PASSIVE = "semantic_slam:passive:ground_truth"
ACTIVE = "semantic_slam:active:ground_truth"
SIZE = {"width": 48, "height": 36, "arch": "cpu"}
#: The task's observations (images, their intrinsics, the laser from the images' launch, the poses).
NAMES = None
#: Sensor noise drawn per frame (from the frame count): a render taken from the hint must get the same draws.
NOISE = {"rgb_sigma": 3.0, "depth_sigma": 0.01, "depth_dropout": 0.02, "laser_sigma": 0.01}


def _episode(registry, task: str = PASSIVE, env: str = "miniroom:4") -> Episode:
    from benchbot_sim_taichi.backend import create_backend

    robot = dict(registry.get("robots", "carter"))
    robot["sensors"] = {**robot.get("sensors", {}), "noise": NOISE}
    return Episode(registry.get("tasks", task), robot, registry.scenes(env), create_backend(robot, SIZE))


def _counting_launches(backend) -> list:
    """Record the poses ``backend`` renders at (its ``_launch_render``), in order."""
    launches, launch = [], backend._launch_render

    def counted(pose, with_scan):
        launches.append(np.array(pose))
        return launch(pose, with_scan)

    backend._launch_render = counted
    return launches


def _walk(episode: Episode, steps: int, hint: bool) -> list[dict]:
    frames = [episode.observe(NAMES)]
    for _ in range(steps):
        if hint:
            episode.prefetch_next()
        episode.act("move_next")
        frames.append(episode.observe(NAMES))
    return frames


def _assert_same(a, b, where: str = "") -> None:
    if isinstance(a, dict):
        assert a.keys() == b.keys(), where
        for k in a:
            _assert_same(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), where
    else:
        assert a == b, where


def test_hinted_steps_give_the_same_bits_and_render_ahead(registry):
    plain = _episode(registry)
    try:
        expected = _walk(plain, 6, hint=False)
    finally:
        plain.backend.close()
    hinted = _episode(registry)
    try:
        launches = _counting_launches(hinted.backend)
        frames = [hinted.observe(NAMES)]
        taken_in_observe = 0
        for _ in range(6):
            hinted.prefetch_next()  # renders ahead at the pose move_next will reach (none where it stays put)
            hinted.act("move_next")
            before = len(launches)
            frames.append(hinted.observe(NAMES))
            taken_in_observe += len(launches) - before
            np.testing.assert_array_equal(launches[-1], hinted.backend.base_pose())
        assert len(launches) >= 6 and taken_in_observe == 0  # every new pose's render came from its hint
    finally:
        hinted.backend.close()
    for i, (got, want) in enumerate(zip(frames, expected)):
        _assert_same(got, want, f"frame {i}")


def test_a_hint_not_taken_changes_nothing(registry):
    plain = _episode(registry)
    try:
        plain.act("move_next")
        plain.reset()
        expected = _walk(plain, 2, hint=False)
    finally:
        plain.backend.close()
    hinted = _episode(registry)
    try:
        hinted.observe(NAMES)
        hinted.prefetch_next()
        hinted.act("move_next")
        hinted.prefetch_next()  # the client resets instead of moving on: this render is never used
        hinted.reset()
        assert hinted.backend._prefetched is None
        got = _walk(hinted, 2, hint=False)
    finally:
        hinted.backend.close()
    for i, (a, b) in enumerate(zip(got, expected)):
        _assert_same(a, b, f"frame {i}")


def test_no_hint_where_the_next_action_is_not_known(registry):
    active = _episode(registry, ACTIVE, "miniroom:1")
    try:
        active.prefetch_next()  # an active task: any action may come next
        assert active.backend._prefetched is None
    finally:
        active.backend.close()
    passive = _episode(registry)
    try:
        trajectory = passive.environment["trajectory_poses"]
        for _ in trajectory:
            passive.act("move_next")
        assert passive.is_finished
        passive.prefetch_next()  # nothing comes after the last pose
        assert passive.backend._prefetched is None
    finally:
        passive.backend.close()


def test_the_native_step_hints_the_backend_over_http(served):
    """Over a real HTTP server on loopback: after a step's reply, the backend thread renders the next pose."""
    from benchbot.api.benchbot import BenchBot

    service, server = served(PASSIVE, "miniroom:4")
    backend = service.episode.backend
    client = BenchBot(supervisor_address=server.address)
    try:
        client.step("move_next")  # the trajectory's first pose is the start pose: the hint is for the second
        service.call(lambda: None)  # the backend thread has done what was queued behind the step
        assert backend._prefetched is not None
        pose = backend._prefetched[0]
        client.step("move_next")
        service.call(lambda: None)
        np.testing.assert_array_equal(backend.base_pose(), pose)  # the second step went where the hint rendered
    finally:
        client.close()
