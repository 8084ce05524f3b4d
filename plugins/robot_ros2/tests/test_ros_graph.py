"""The Cyclone DDS transport announces itself to ROS 2 tools as rmw_cyclonedds_cpp (Jazzy) does: the participant's
USER_DATA ``enclave=/;``, each endpoint's ``typehash=RIHS01_...;``, and ``ros_discovery_info`` naming the node and
its endpoints' GIDs. Everything is read back by an independent participant (DDS built-in topics, rosbags' CDR
decoder), following the rules of rmw_cyclonedds_cpp's graph cache."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from benchbot_robot_ros2.msgs import TYPE_HASHES, TYPES
from benchbot_robot_ros2.transport import CycloneTransport, check_node_name, type_hash_user_data

sys.path.insert(0, str(Path(__file__).parent))
from ros2_independent import TYPESTORE, RawListener, discovered  # noqa: E402


#: rmw_dds_common's types, whose ``char`` fields rosbags hashes differently from Jazzy: their hashes are checked
#: against the real Jazzy type descriptions instead (test_rclpy.py, in the ROS 2 environment).
ROSBAGS_DIFFERS = {"rmw_dds_common/msg/Gid", "rmw_dds_common/msg/NodeEntitiesInfo",
                   "rmw_dds_common/msg/ParticipantEntitiesInfo"}


def test_type_hashes_match_an_independent_implementation():
    """Every type hash we announce (but rmw_dds_common's) equals rosbags' RIHS01 of ROS 2 Jazzy's definition; one of
    them is also the value ``ros2 topic info -v`` prints for sensor_msgs/msg/Image on Jazzy; rmw_dds_common's are
    not rosbags' (whose differ from Jazzy's)."""
    assert set(TYPE_HASHES) == set(TYPES)
    for ros_type, rihs in TYPE_HASHES.items():
        if ros_type in ROSBAGS_DIFFERS:
            assert TYPESTORE.hash_rihs01(ros_type) != rihs, ros_type
        else:
            assert TYPESTORE.hash_rihs01(ros_type) == rihs, ros_type
    assert TYPE_HASHES["rmw_dds_common/msg/Gid"] == \
        "RIHS01_ab6f21cfbb0a6dbb837161e1110c2051a2850ed9f9c53944d7115d9bcebedf71"  # share/rmw_dds_common/msg/Gid.json
    assert TYPE_HASHES["sensor_msgs/msg/Image"] == \
        "RIHS01_d31d41a9a4c4bc8eae9be757b0beed306564f7526c88ea6a4588fb9582527d47"
    assert type_hash_user_data("sensor_msgs/Image") == f"typehash={TYPE_HASHES['sensor_msgs/msg/Image']};".encode()


@pytest.mark.slow
def test_node_is_announced_as_rmw_does(domain_id):
    dom = domain_id + 30
    tr = CycloneTransport(dom, "loopback", node_name="benchbot_probe")
    pub = tr.publisher("/probe/scan", "sensor_msgs/msg/LaserScan")
    tr.subscribe("/probe/cmd_vel", "geometry_msgs/msg/Twist", lambda m: None, reliable=True)
    info = RawListener(dom, "ros_discovery_info", "rmw_dds_common/msg/ParticipantEntitiesInfo", latched=True,
                       dds_name=True)
    try:
        graph = discovered(dom)
        me = tr.participant.guid.bytes
        # the participant: enclave in USER_DATA (rmw adds participants to its graph cache only then)
        assert graph["participants"][me] == b"enclave=/;"
        # its endpoints: ROS topic and type names, the type hash in USER_DATA
        pubs = {p["topic"]: p for p in graph["publications"] if p["participant"] == me}
        subs = {s["topic"]: s for s in graph["subscriptions"] if s["participant"] == me}
        assert pubs["rt/probe/scan"]["type"] == "sensor_msgs::msg::dds_::LaserScan_"
        assert pubs["rt/probe/scan"]["user_data"] == \
            b"typehash=RIHS01_64c191398013af96509d518dac71d5164f9382553fce5c1f8cca5be7924bd828;"
        assert subs["rt/probe/cmd_vel"]["user_data"] == f"typehash={TYPE_HASHES['geometry_msgs/msg/Twist']};".encode()
        assert pubs["ros_discovery_info"]["type"] == "rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_"
        # ros_discovery_info (decoded by rosbags): this participant's node with exactly its endpoints' GIDs
        msgs = info.wait(lambda ms: any(bytes(m.gid.data) == me and m.node_entities_info_seq
                                        and len(m.node_entities_info_seq[0].reader_gid_seq) == 1 for m in ms))
        latest = [m for m in msgs if bytes(m.gid.data) == me][-1]
        (node,) = latest.node_entities_info_seq
        assert (node.node_namespace, node.node_name) == ("/", "benchbot_probe")
        assert {bytes(g.data) for g in node.writer_gid_seq} == {pubs["rt/probe/scan"]["gid"]}
        assert {bytes(g.data) for g in node.reader_gid_seq} == {subs["rt/probe/cmd_vel"]["gid"]}
    finally:
        info.close()
        tr.close()
    del pub


def test_node_names_are_checked():
    assert check_node_name("benchbot_sim") == "benchbot_sim"
    for bad in ("", "1robot", "my-robot", "a/b"):
        with pytest.raises(ValueError, match="node name"):
            check_node_name(bad)


def test_docs_give_the_loopback_configuration_verbatim():
    """docs/ros2.md tells ROS 2 users to export exactly the configuration serve-sim and carter_ros2 use."""
    from benchbot_robot_ros2.transport import LOOPBACK_URI

    docs = (Path(__file__).resolve().parents[3] / "docs" / "ros2.md").read_text()
    assert f"export CYCLONEDDS_URI='{LOOPBACK_URI}'" in docs
