"""An episode's clock: a real robot (an environment of type ``real``) runs on the wall clock, a simulator
on simulated time; the batch manifest's episode ``backend`` says which (the recording's metadata is checked end to
end by ``plugins/robot_ros2/tests/test_real_room.py``)."""

from __future__ import annotations

from benchbot.batch.provenance import backend_facts
from benchbot.core.robot import episode_clock


def test_a_real_environment_is_on_the_wall_clock():
    assert episode_clock([{"name": "lab", "variant": 1, "type": "real"}]) == "wall"
    assert episode_clock([{"name": "miniroom", "variant": 1, "type": "sim_taichi"}]) == "simulated"
    assert episode_clock([]) == "simulated"


def test_the_manifest_s_backend_facts_name_the_clock(registry):
    robot = registry.get("robots", "turtlebot4")
    assert backend_facts(registry, robot, [{"name": "lab", "variant": 1, "type": "real"}])["clock"] == "wall"
    carter = registry.get("robots", "carter")
    assert backend_facts(registry, carter, registry.scenes("miniroom:1"))["clock"] == "simulated"
