"""Independent readers for the ROS 2 convention tests: DDS samples taken as raw CDR bytes (never through the
plugin's IDL codecs) and decoded by ``rosbags`` with ROS 2 Jazzy's message definitions; the DDS discovery data
(participants, publications, subscriptions) as Cyclone DDS's built-in topics give them, which is what
rmw_cyclonedds_cpp's graph cache reads."""

from __future__ import annotations

import threading
import time
from typing import Any, Callable

from rosbags.typesys import Stores, get_typestore

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)


def decode(raw: bytes, ros_type: str) -> Any:
    """CDR bytes (with the 4-byte encapsulation header) → a rosbags message of ``ros_type``."""
    return TYPESTORE.deserialize_cdr(raw, ros_type)


class RawListener:
    """A DDS participant of its own reading ``topic`` (ROS name, or a plain DDS name with ``dds_name=True``) as raw
    bytes: ``messages`` holds ``(receipt monotonic time, rosbags message)``, decoded by rosbags.

    Args:
        domain_id: the DDS domain.
        topic: ROS 2 topic (``/scan``) or, with ``dds_name``, the DDS topic name (``ros_discovery_info``).
        ros_type: ``pkg/msg/Name``.
        reliable, latched: the reader's QoS (best-effort volatile by default).
    """

    def __init__(self, domain_id: int, topic: str, ros_type: str, *, reliable: bool = False, latched: bool = False,
                 dds_name: bool = False) -> None:
        from cyclonedds.core import Listener, Policy, Qos
        from cyclonedds.domain import DomainParticipant
        from cyclonedds.sub import DataReader
        from cyclonedds.topic import Topic

        from benchbot_robot_ros2.msgs import dds_topic, message_class

        self.ros_type = ros_type
        self.messages: list[tuple[float, Any]] = []
        self.errors: list[str] = []
        self.cond = threading.Condition()
        self.participant = DomainParticipant(domain_id)
        name = topic if dds_name else dds_topic(topic)
        self.topic = Topic(self.participant, name, message_class(ros_type))  # the DDS type name; never decoded by it
        qos = Qos(Policy.Reliability.Reliable(max_blocking_time=100_000_000) if (reliable or latched)
                  else Policy.Reliability.BestEffort,
                  Policy.History.KeepLast(100),
                  Policy.Durability.TransientLocal if latched else Policy.Durability.Volatile)

        def on_data(reader: Any) -> None:
            from cyclonedds._clayer import ddspy_take
            from cyclonedds.core import InstanceState, SampleState, ViewState

            reader = reader if reader is not None else getattr(self, "reader", None)
            if reader is None:  # called while the reader is being built: the call after it takes the samples
                return
            ret = ddspy_take(reader._ref, SampleState.Any | ViewState.Any | InstanceState.Any, 100)
            if isinstance(ret, int):
                self.errors.append(f"take failed: {ret}")
                return
            for data, info in ret:
                if info.valid_data:
                    self._on_raw(bytes(data))

        self.reader = DataReader(self.participant, self.topic, qos=qos, listener=Listener(on_data_available=on_data))
        on_data(self.reader)

    def _on_raw(self, raw: bytes) -> None:
        try:
            msg = decode(raw, self.ros_type)
        except Exception as exc:  # noqa: BLE001
            self.errors.append(f"rosbags cannot decode a {self.ros_type}: {exc!r}")
            return
        with self.cond:
            self.messages.append((time.monotonic(), msg))
            self.cond.notify_all()

    def wait(self, predicate: Callable[[list], bool], timeout: float = 30.0) -> list:
        """Wait until ``predicate(messages)`` holds (returns the messages) or fail with what was received."""
        deadline = time.monotonic() + timeout
        with self.cond:
            while not predicate([m for _, m in self.messages]):
                left = deadline - time.monotonic()
                if left <= 0:
                    raise AssertionError(f"{self.ros_type}: condition not met in {timeout} s "
                                         f"({len(self.messages)} received; errors {self.errors[:3]})")
                self.cond.wait(min(left, 0.2))
            return [m for _, m in self.messages]

    def close(self) -> None:
        """Drop the participant (and its reader). The listener goes first, on this thread (Cyclone DDS waits for a
        callback in progress): a listener thread must never drop the last reference to its own reader, which deletes
        it inside its callback and hangs (as ``CycloneTransport.close`` once did)."""
        if self.reader is not None:
            self.reader.set_listener(None)
        self.reader = self.topic = self.participant = None


def discovered(domain_id: int, wait_s: float = 3.0) -> dict:
    """What DDS discovery shows on ``domain_id`` after ``wait_s`` seconds, read through Cyclone DDS's built-in
    topics by a participant of its own: ``{'participants': {guid bytes: user_data bytes}, 'publications': [...],
    'subscriptions': [...]}`` with endpoints as ``{'gid', 'participant', 'topic', 'type', 'user_data'}``."""
    from cyclonedds.builtin import (BuiltinDataReader, BuiltinTopicDcpsParticipant, BuiltinTopicDcpsPublication,
                                    BuiltinTopicDcpsSubscription)
    from cyclonedds.domain import DomainParticipant

    dp = DomainParticipant(domain_id)
    readers = {name: BuiltinDataReader(dp, topic) for name, topic in (
        ("participants", BuiltinTopicDcpsParticipant), ("publications", BuiltinTopicDcpsPublication),
        ("subscriptions", BuiltinTopicDcpsSubscription))}
    time.sleep(wait_s)
    out: dict = {"participants": {}, "publications": [], "subscriptions": []}
    for sample in readers["participants"].read(N=1000):
        out["participants"][sample.key.bytes] = _user_data(sample.qos)
    for kind in ("publications", "subscriptions"):
        for s in readers[kind].read(N=1000):
            out[kind].append({"gid": s.key.bytes, "participant": s.participant_key.bytes, "topic": s.topic_name,
                              "type": s.type_name, "user_data": _user_data(s.qos)})
    return out


def _user_data(qos: Any) -> bytes:
    from cyclonedds.core import Policy

    for policy in qos:
        if isinstance(policy, Policy.Userdata):
            return bytes(policy.data)
    return b""
