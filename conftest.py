"""Test-wide settings: only the first-party plugins load, whatever else is installed (architecture.md)."""

import os

os.environ["BENCHBOT_ONLY_PLUGINS"] = "core_examples,sim_taichi,eval_omq,task_semslam"
