"""Hook implementations of the ``task_semslam`` plugin: the six semantic SLAM / scene change detection tasks and
their three object-map formats (YAML specs next to this module)."""

from __future__ import annotations

from pathlib import Path

from benchbot.core.hookspecs import hookimpl

_HERE = Path(__file__).resolve().parent
TASKS_DIR = _HERE / "tasks"
FORMATS_DIR = _HERE / "formats"


@hookimpl
def benchbot_tasks() -> list[Path]:
    """Return the folder of the six task specs (``semantic_slam:*``, ``scd:*``) in ``tasks/``."""
    return [TASKS_DIR]


@hookimpl
def benchbot_formats() -> list[Path]:
    """Return the folder of the ``object_map``, ``object_map_with_states`` and ``object_map_ground_truth`` format
    specs in ``formats/``."""
    return [FORMATS_DIR]


EXAMPLES_DIR = Path(__file__).parent / "examples"


@hookimpl
def benchbot_examples() -> list[Path]:
    """Return the folder of the example specs in ``examples/`` (``semslam_geometric``, ``semslam_detector``)."""
    return [EXAMPLES_DIR]
