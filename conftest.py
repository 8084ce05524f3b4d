"""Test-wide settings: only the first-party plugins load, whatever else is installed (architecture.md), and content
packs come from an empty, per-session data directory, never from the user's."""

import os
import tempfile

os.environ["BENCHBOT_ONLY_PLUGINS"] = "core_examples,content_packs,sim_taichi,eval_omq,task_semslam,robot_ros2,assets_sh3d"
os.environ["BENCHBOT_DATA_DIR"] = tempfile.mkdtemp(prefix="benchbot-test-data-")
