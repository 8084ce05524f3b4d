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
