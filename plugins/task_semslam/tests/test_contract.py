"""task_semslam against the core's contract checks (benchbot.plugins.testing): content, tasks and formats."""

from __future__ import annotations

from benchbot.core.specs import expand_spec_folders
from benchbot.plugins import testing


def test_plugin_content_contract():
    from benchbot_task_semslam import plugin

    registers = testing.check_content_plugin(plugin)
    assert len(registers["tasks"]) == 6 and "object_map" in registers["formats"]


def test_tasks_and_formats_contract():
    from benchbot.core.registry import get_registry
    from benchbot_task_semslam import plugin

    reg = get_registry()
    for path in expand_spec_folders(plugin.benchbot_tasks()):
        testing.check_task(path, registry=reg, robots=["carter"] if "carter" in reg.entries["robots"] else [])
    for path in expand_spec_folders(plugin.benchbot_formats()):
        assert isinstance(testing.check_format(path), dict)
