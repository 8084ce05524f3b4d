"""BenchBot plugin: ROS 2 robots."""
