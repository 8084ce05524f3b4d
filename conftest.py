"""Test-wide settings: only the first-party plugins load, whatever else is installed (architecture.md), and content
packs come from an empty, per-session data directory, never from the user's. Environments that name no style are
drawn in sim_taichi's ``primitives`` style (fast to build); the tests of the furnished default name it, and
``tests/test_furnished_episode.py`` runs the README's main job on it."""

import os
import tempfile

os.environ["BENCHBOT_ONLY_PLUGINS"] = "core_examples,content_packs,sim_taichi,eval_omq,task_semslam,robot_ros2,assets_sh3d"
os.environ["BENCHBOT_DATA_DIR"] = tempfile.mkdtemp(prefix="benchbot-test-data-")
os.environ["BENCHBOT_SIM_STYLE"] = "primitives"
