"""benchbot_sim_taichi.kinematics: N robots driven together move as each does alone; the near-obstacle shortlist
gives the collisions that checking every obstacle gives."""

from __future__ import annotations

import numpy as np

from benchbot_sim_taichi.kinematics import Obstacles, drive, drive_robots


def _clutter(seed: int, count: int = 60) -> Obstacles:
    rng = np.random.default_rng(seed)
    lo = rng.uniform(0.0, 12.0, (count, 2))
    return Obstacles(lo, lo + rng.uniform(0.05, 0.5, (count, 2)), [f"box{i}" for i in range(count)],
                     np.array([-0.5, -0.5]), np.array([12.5, 12.5]), 0.25)


def test_robots_driven_together_move_as_each_alone():
    obstacles = _clutter(1)
    rng = np.random.default_rng(2)
    poses = np.column_stack([rng.uniform(0, 12, 64), rng.uniform(0, 12, 64), rng.uniform(-3, 3, 64)])
    goals = poses + np.column_stack([rng.uniform(-1.5, 1.5, (64, 2)), rng.uniform(-3, 3, 64)])
    together, collided, seconds = drive_robots(poses, goals, obstacles)
    for i in range(64):
        alone, outcome = drive(poses[i], goals[i], obstacles)
        assert np.array_equal(together[i], alone), i
        assert (collided[i], seconds[i]) == (outcome.collided, outcome.duration_s), i
    assert 5 < collided.sum() < 60  # the clutter stopped some robots and not others


def test_the_near_shortlist_finds_every_contact():
    obstacles = _clutter(3)
    rng = np.random.default_rng(4)
    start = rng.uniform(0, 12, (2000, 2))
    reach = 0.6
    near = obstacles.near(start, reach)
    assert near.shape[1] < 20  # a shortlist, not all 60 boxes
    angle = rng.uniform(-np.pi, np.pi, 2000)
    moved = start + reach * rng.uniform(0, 1, (2000, 1)) * np.column_stack([np.cos(angle), np.sin(angle)])
    everything, _ = obstacles.clearances(moved)
    shortlisted, _ = obstacles.clearances(moved, among=near)
    assert np.array_equal(everything <= 0, shortlisted <= 0)
    assert 100 < (everything <= 0).sum() < 1900


def _tick_by_tick(pose: np.ndarray, goal: np.ndarray, obstacles: Obstacles) -> tuple[np.ndarray, bool, int]:
    """The reference: the controller stepped in the map frame, every obstacle checked before each tick."""
    from benchbot.core.motion import ControllerGains, PoseControllers, integrate_unicycles

    gains = ControllerGains()
    ctl, pose, ticks = PoseControllers(goal[None], gains), pose[None].astype(np.float64), 0
    while ctl.command(pose)[0]:
        nxt = integrate_unicycles(pose, ctl.v, ctl.w, 1.0 / gains.rate_hz)
        if obstacles.collides(nxt[0, :2]):
            return pose[0], True, ticks
        pose, ticks = nxt, ticks + 1
    return pose[0], False, ticks


def test_drive_robots_matches_the_tick_by_tick_reference_in_blocks(monkeypatch):
    """Against every obstacle checked at every tick (no shortlist, no shared paths), also when the checks are split
    into many blocks of robots (the memory bound)."""
    from benchbot_sim_taichi import kinematics

    obstacles = _clutter(5)
    rng = np.random.default_rng(6)
    poses = np.column_stack([rng.uniform(0, 12, 40), rng.uniform(0, 12, 40), rng.uniform(-3, 3, 40)])
    goals = poses + np.column_stack([rng.uniform(-2, 2, (40, 2)), rng.uniform(-3, 3, 40)])
    whole = drive_robots(poses, goals, obstacles)
    monkeypatch.setattr(kinematics, "CHECK_PAIRS", 50)  # one robot a block
    blocks = drive_robots(poses, goals, obstacles)
    for a, b in zip(whole, blocks):
        assert np.array_equal(a, b)
    final, collided, seconds = whole
    for i in range(40):
        pose, hit, ticks = _tick_by_tick(poses[i], goals[i], obstacles)
        np.testing.assert_allclose(final[i], pose, atol=1e-6, err_msg=str(i))
        assert collided[i] == hit, i
        assert abs(seconds[i] - (ticks / 20.0 + (0 if hit else 0.65))) < 1e-9, i
    assert 3 < collided.sum() < 37


def test_drive_robots_edge_cases():
    """No robots; no obstacle boxes (walls only); a goal equal to the pose (no motion, settle time only)."""
    walls = Obstacles(np.zeros((0, 2)), np.zeros((0, 2)), [], np.array([-5.0, -5.0]), np.array([5.0, 5.0]), 0.2)
    for obstacles in (walls, _clutter(1), None):
        final, collided, seconds = drive_robots(np.zeros((0, 3)), np.zeros((0, 3)), obstacles)
        assert final.shape == (0, 3) and collided.shape == seconds.shape == (0,)
    poses = np.array([[0.0, 0.0, 0.0], [1.0, -1.0, 0.3], [0.0, 0.0, 0.0]])
    goals = np.array([[1.0, 0.5, 0.0], [1.0, -1.0, 0.3], [9.0, 0.0, 0.0]])  # the third drives into the wall
    final, collided, seconds = drive_robots(poses, goals, walls)
    np.testing.assert_allclose(final[0], goals[0], atol=0.02)
    assert np.array_equal(final[1], poses[1]) and seconds[1] == 0.65
    assert collided.tolist() == [False, False, True] and 4.5 < final[2, 0] < 4.81
