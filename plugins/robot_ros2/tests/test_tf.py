"""The TF buffer: a lookup sees every edge of a TF message or none of them, and stale edges count as lost."""

from __future__ import annotations

import time
from types import SimpleNamespace as NS

import numpy as np
import pytest

from benchbot_robot_ros2 import tf as tf_module
from benchbot_robot_ros2.tf import TfBuffer, TfLookupError


def edge(parent: str, child: str, x: float) -> NS:
    """A ``geometry_msgs/TransformStamped`` look-alike: ``child`` at ``x`` m along ``parent``'s x axis."""
    return NS(header=NS(frame_id=parent), child_frame_id=child,
              transform=NS(translation=NS(x=x, y=0.0, z=0.0), rotation=NS(x=0.0, y=0.0, z=0.0, w=1.0)))


def message(x: float) -> NS:
    """A ``tf2_msgs/TFMessage`` look-alike with map → odom → base_link, as a robot's localiser and odometry."""
    return NS(transforms=[edge("map", "odom", 0.0), edge("odom", "base_link", x)])


def test_a_lookup_during_a_message_sees_none_of_its_edges_or_all(monkeypatch):
    """After a pause longer than ``max_age_s`` (a process that was not scheduled), a lookup made while the next
    message is being stored must not find its first edge new and its second one stale (CI once faulted a robot on
    exactly that: 'odom → base_link was received 1.51 s before the newest transform')."""
    buf = TfBuffer(max_age_s=0.05)
    buf.add_message(message(1.0))
    time.sleep(0.1)
    seen = []
    real = tf_module.transform_to_matrix

    def converting_then_looking_up(tr):
        if tr.translation.x == 2.0:  # the second edge of the second message: look up mid-message
            seen.append(buf.lookup("map", "base_link")[0, 3])
        return real(tr)

    monkeypatch.setattr(tf_module, "transform_to_matrix", converting_then_looking_up)
    buf.add_message(message(2.0))
    assert seen == [1.0]  # the previous message, whole
    assert buf.lookup("map", "base_link")[0, 3] == 2.0


def test_an_edge_older_than_max_age_behind_the_newest_is_lost():
    """A localiser that stops (map → odom no longer received) while odometry goes on: the lookup through it fails."""
    buf = TfBuffer(max_age_s=0.05)
    buf.add_message(message(1.0))
    time.sleep(0.1)
    buf.add_message(NS(transforms=[edge("odom", "base_link", 3.0)]))
    with pytest.raises(TfLookupError, match=r"map → odom was received .* before the newest transform"):
        buf.lookup("map", "base_link")


def test_static_edges_never_age_and_malformed_entries_are_reported_after_the_good_ones():
    buf = TfBuffer(max_age_s=0.05)
    buf.add_message(NS(transforms=[edge("base_link", "lidar", 0.2)]), static=True)
    with pytest.raises(ValueError, match="malformed transform"):
        buf.add_message(NS(transforms=[edge("odom", "odom", 0.0), edge("odom", "base_link", 1.0)]))
    time.sleep(0.1)
    np.testing.assert_allclose(buf.lookup("odom", "lidar")[:3, 3], [1.2, 0.0, 0.0])
