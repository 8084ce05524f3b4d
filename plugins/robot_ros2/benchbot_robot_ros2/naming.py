"""ROS 2 naming conventions, free of any DDS import."""

from __future__ import annotations


def normalise_type(ros_type: str) -> str:
    """``pkg/Name`` or ``pkg/msg/Name`` → ``pkg/msg/Name`` (ROS 1 style names of the original's YAML accepted)."""
    parts = str(ros_type).strip().split("/")
    if len(parts) == 2:
        parts = [parts[0], "msg", parts[1]]
    return "/".join(parts)


def dds_topic(ros_topic: str) -> str:
    """ROS 2 topic name → DDS topic name: ``/cmd_vel`` → ``rt/cmd_vel`` (relative names are taken as absolute)."""
    return "rt/" + str(ros_topic).strip().lstrip("/")
