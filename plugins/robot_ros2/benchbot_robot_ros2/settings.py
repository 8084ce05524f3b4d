"""The environment variables the ROS 2 robot backend reads, declared once (hook ``benchbot_settings`` in
:mod:`benchbot_robot_ros2.plugin`): ``benchbot doctor`` shows them, and the plugin reads them through these
declarations (``settings.get(ROS_DOMAIN_ID)``). Three are ROS 2's own variables (``external``): the plugin reads
them and sets the DDS ones for loopback runs. Imports nothing heavy."""

from __future__ import annotations

from benchbot.core.settings import Setting, whole_number

#: The DDS domain; a ROS 2 domain id is 0..232.
ROS_DOMAIN_ID = Setting("ROS_DOMAIN_ID", "0", "DDS domain of ROS 2 robots and `benchbot ros2 serve-sim`",
                        reader=whole_number(0, 232), external=True)
#: Cyclone DDS's configuration; unset, a loopback run sets it (:func:`benchbot_robot_ros2.transport.configure_network`).
CYCLONEDDS_URI = Setting("CYCLONEDDS_URI", None, "Cyclone DDS configuration (default: discovery on loopback only)",
                         external=True)
#: Fast DDS's profile of rclpy on ``rmw_fastrtps_cpp``; unset, a loopback run sets it.
FASTRTPS_DEFAULT_PROFILES_FILE = Setting("FASTRTPS_DEFAULT_PROFILES_FILE", None, "Fast DDS profile of rclpy on "
                                         "rmw_fastrtps_cpp (default: benchbot_robot_ros2's fastdds_loopback.xml, "
                                         "UDP on 127.0.0.1 only)", external=True)
#: Simulated seconds per wall second, over the robot spec's ``ros2.time_scale`` (checked against the spec's schema
#: by :func:`benchbot_robot_ros2.backend.ros2_config`).
ROS2_TIME_SCALE = Setting("BENCHBOT_ROS2_TIME_SCALE", None, "simulated seconds per wall second of ROS 2 robots (the "
                          "robot spec's time_scale by default)")

#: Every setting of the plugin, in the order ``benchbot doctor`` shows them.
SETTINGS = (ROS_DOMAIN_ID, CYCLONEDDS_URI, FASTRTPS_DEFAULT_PROFILES_FILE, ROS2_TIME_SCALE)
