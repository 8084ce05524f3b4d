"""Publish/subscribe by ROS 2 topic and message type, over ``rclpy`` or directly over Cyclone DDS.

Two implementations of :class:`Transport` behave the same:

* :class:`CycloneTransport`: the ``cyclonedds`` Python package with ROS 2's wire conventions (topics ``rt/<name>``,
  type names ``<pkg>::msg::dds_::<Name>_``, XCDR1): it talks to ROS 2 nodes on ``rmw_cyclonedds_cpp``.
* :class:`RclpyTransport`: a node of ``rclpy`` (a ROS 2 install), used when ``import rclpy`` works.

Messages are built with :meth:`Transport.message` (an object with the ROS field names, nested messages already
built) and read by attribute, so code on top never sees which transport it runs on. Callbacks run on the
transport's own thread; an exception inside one (or a sample that cannot be decoded) is counted in
:attr:`Transport.errors` and never reaches the caller.

QoS: publishers are reliable, keep-last 10 (latched topics such as ``/tf_static``: transient-local); subscribers
are best-effort keep-last 10 (they match reliable and best-effort publishers alike), or reliable/transient-local
where asked (``reliable=True`` for commands, ``latched=True`` for ``/tf_static``).

ROS graph: :class:`CycloneTransport` announces itself as rmw_cyclonedds_cpp (Jazzy) does, so ROS 2 tools see one
node (``ros2 node list``, ``ros2 node info``, ``ros2 topic info -v``): the participant's USER_DATA is
``enclave=/;``, every reader's and writer's USER_DATA is ``typehash=RIHS01_<hex>;`` (the type's REP 2011 hash), and
a ``rmw_dds_common/msg/ParticipantEntitiesInfo`` on the DDS topic ``ros_discovery_info`` (reliable,
transient-local, keep-last 1) lists the node (namespace ``/``, ``node_name``) with the GIDs (DDS GUIDs) of its
readers and writers, re-published whenever one is created.

Network: ``network='loopback'`` confines Cyclone DDS to the ``lo`` interface (multicast off, peer 127.0.0.1) by
setting ``CYCLONEDDS_URI`` before the first participant, and Fast DDS (rclpy on ``rmw_fastrtps_cpp``) to UDP on
127.0.0.1 by setting ``FASTRTPS_DEFAULT_PROFILES_FILE`` (:data:`FASTDDS_LOOPBACK_PROFILE`) — each unless the user
has set it already, which always wins. ``network='system'`` leaves DDS configuration to the environment (a real
robot on a LAN).
"""

from __future__ import annotations

import abc
import importlib
import logging
import os
import re
import threading
from pathlib import Path
from typing import Any, Callable, Iterable

from benchbot.core import settings
from benchbot_robot_ros2.settings import CYCLONEDDS_URI, FASTRTPS_DEFAULT_PROFILES_FILE

log = logging.getLogger(__name__)

LOOPBACK_URI = (
    '<CycloneDDS><Domain><General><Interfaces><NetworkInterface name="lo"/></Interfaces>'
    "<AllowMulticast>false</AllowMulticast></General><Discovery><Peers><Peer address=\"127.0.0.1\"/></Peers>"
    "<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>50</MaxAutoParticipantIndex></Discovery>"
    "</Domain></CycloneDDS>"
)


FASTDDS_LOOPBACK_PROFILE = Path(__file__).with_name("fastdds_loopback.xml")
"""A Fast DDS XML profile (the default participant profile) that confines Fast DDS — ``rmw_fastrtps_cpp``, Jazzy's
default RMW — to UDP on 127.0.0.1: no shared memory, no multicast, discovery by unicast to 127.0.0.1 for participant
indices 0-50, as :data:`LOOPBACK_URI` does for Cyclone DDS; the two then find each other both ways
(docs/ros2.md). ``export FASTRTPS_DEFAULT_PROFILES_FILE=<this file>`` for ROS 2 nodes on the same machine."""


def configure_network(network: str = "loopback") -> None:
    """For ``network='loopback'``: set ``CYCLONEDDS_URI`` to :data:`LOOPBACK_URI` and
    ``FASTRTPS_DEFAULT_PROFILES_FILE`` to :data:`FASTDDS_LOOPBACK_PROFILE`, each unless it is already set (yours
    always wins). Both are read when a DDS participant is made, so this must run before the first one.

    Raises:
        ValueError: ``network`` is neither ``loopback`` nor ``system``.
    """
    if network not in ("loopback", "system"):
        raise ValueError(f"ros2.network must be 'loopback' or 'system', got {network!r}")
    if network == "loopback" and not settings.get(CYCLONEDDS_URI):
        os.environ["CYCLONEDDS_URI"] = LOOPBACK_URI
    if network == "loopback" and not settings.get(FASTRTPS_DEFAULT_PROFILES_FILE):
        os.environ["FASTRTPS_DEFAULT_PROFILES_FILE"] = str(FASTDDS_LOOPBACK_PROFILE)


def rclpy_available() -> bool:
    """Whether ``import rclpy`` works (a sourced ROS 2 install)."""
    try:
        importlib.import_module("rclpy")
        return True
    except Exception:  # noqa: BLE001 - any failure means no usable rclpy
        return False


class Publisher(abc.ABC):
    """A publisher on one topic."""

    @abc.abstractmethod
    def publish(self, msg: Any) -> None:
        """Send ``msg`` (built with :meth:`Transport.message` for this publisher's type)."""


class Transport(abc.ABC):
    """Publish/subscribe by topic and ROS 2 type name (``pkg/msg/Name``).

    Attributes:
        name: ``'cyclonedds'`` or ``'rclpy'``.
        errors: count of callbacks that raised and of samples that could not be decoded.
    """

    name = "abstract"

    def __init__(self) -> None:
        self.errors = 0
        self.last_error = ""

    @abc.abstractmethod
    def message(self, ros_type: str) -> Any:
        """A new message of ``ros_type`` with default field values."""

    @abc.abstractmethod
    def publisher(self, topic: str, ros_type: str, *, latched: bool = False) -> Publisher:
        """A publisher of ``ros_type`` on ROS 2 topic ``topic`` (e.g. ``/cmd_vel``)."""

    @abc.abstractmethod
    def subscribe(self, topic: str, ros_type: str, callback: Callable[[Any], None], *, latched: bool = False,
                  reliable: bool = False) -> Any:
        """Call ``callback(msg)`` for each message on ``topic``; returns a handle kept alive by the transport."""

    def poll(self, topics: "Iterable[str] | None" = None) -> int:
        """Deliver now, on the calling thread, the messages of ``topics`` (None: every subscribed topic) that have
        arrived but that the transport's own thread has not handed to their callbacks yet: a watchdog calls it
        before judging a topic silent, so that messages queued while this process was not scheduled count
        (:mod:`benchbot_robot_ros2.watchdog`). Never blocks on the transport's thread: what that thread is
        delivering right now it delivers itself. Returns how many messages were delivered here (0 by default)."""
        return 0

    def close(self) -> None:
        """Release the participant/node."""

    def _guard(self, callback: Callable[[Any], None], msg: Any) -> None:
        try:
            callback(msg)
        except Exception as exc:  # noqa: BLE001 - a bad message must not kill the transport thread
            self.errors += 1
            self.last_error = repr(exc)
            log.debug("callback failed: %r", exc)


class _CyclonePublisher(Publisher):
    def __init__(self, writer: Any, cls: type) -> None:
        self.writer, self.cls = writer, cls

    def publish(self, msg: Any) -> None:
        self.writer.write(msg)


DEFAULT_NODE_NAME = "benchbot_robot_ros2"
_NODE_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,254}")


def check_node_name(node_name: str) -> str:
    """``node_name`` if it is a valid ROS 2 node name (letters, digits, underscores; not starting with a digit).

    Raises:
        ValueError: it is not.
    """
    if not isinstance(node_name, str) or not _NODE_NAME.fullmatch(node_name):
        raise ValueError(f"ROS 2 node name {node_name!r} is not valid (letters, digits and '_', not starting with "
                         "a digit)")
    return node_name


def type_hash_user_data(ros_type: str) -> bytes:
    """The USER_DATA rmw_cyclonedds_cpp gives a reader or writer of ``ros_type``: ``b'typehash=RIHS01_<hex>;'``.

    Raises:
        KeyError: a type this transport does not know.
    """
    from benchbot_robot_ros2.msgs import TYPE_HASHES, normalise_type

    return f"typehash={TYPE_HASHES[normalise_type(ros_type)]};".encode()


class CycloneTransport(Transport):
    """:class:`Transport` over one Cyclone DDS domain participant, announced to ROS 2 as one node (module doc).

    Args:
        domain_id: the DDS domain (ROS_DOMAIN_ID), 0..232.
        network: ``'loopback'`` (default) or ``'system'`` (see the module doc).
        node_name: the ROS 2 node name the participant announces (namespace ``/``).

    Attributes:
        node_name: as given. reader_gids, writer_gids: the 16-byte GIDs of this node's readers and writers.

    Raises:
        ValueError: ``network`` or ``node_name`` is not valid.
    """

    name = "cyclonedds"

    def __init__(self, domain_id: int = 0, network: str = "loopback", node_name: str = DEFAULT_NODE_NAME) -> None:
        super().__init__()
        configure_network(network)
        self.node_name = check_node_name(node_name)
        from cyclonedds.core import Policy, Qos
        from cyclonedds.domain import DomainParticipant
        from cyclonedds.pub import DataWriter
        from cyclonedds.topic import Topic

        from benchbot_robot_ros2.msgs import ParticipantEntitiesInfo

        self.domain_id = int(domain_id)
        self.participant = DomainParticipant(self.domain_id, qos=Qos(Policy.Userdata(data=b"enclave=/;")))
        self._topics: dict[str, Any] = {}
        self._keep: list[Any] = []
        self._pollers: list[tuple[str, Any, Callable[[Any], int]]] = []  # (topic, reader, poll) per subscription
        self._lock = threading.Lock()
        self.reader_gids: list[bytes] = []
        self.writer_gids: list[bytes] = []
        info_qos = Qos(
            Policy.Reliability.Reliable(max_blocking_time=100_000_000), Policy.History.KeepLast(1),
            Policy.Durability.TransientLocal, Policy.DataRepresentation(use_cdrv0_representation=True),
            Policy.Userdata(data=type_hash_user_data("rmw_dds_common/msg/ParticipantEntitiesInfo")))
        self._discovery = DataWriter(self.participant, Topic(self.participant, "ros_discovery_info",
                                                             ParticipantEntitiesInfo), qos=info_qos)
        self._announce()

    def _announce(self) -> None:
        """Publish this participant's node and its endpoints on ``ros_discovery_info``."""
        from benchbot_robot_ros2.msgs import Gid, NodeEntitiesInfo, ParticipantEntitiesInfo

        with self._lock:
            node = NodeEntitiesInfo(node_namespace="/", node_name=self.node_name,
                                    reader_gid_seq=[Gid(data=list(g)) for g in self.reader_gids],
                                    writer_gid_seq=[Gid(data=list(g)) for g in self.writer_gids])
            info = ParticipantEntitiesInfo(gid=Gid(data=list(self.participant.guid.bytes)),
                                           node_entities_info_seq=[node])
            self._discovery.write(info)

    def message(self, ros_type: str) -> Any:
        from benchbot_robot_ros2.msgs import message_class

        return message_class(ros_type)()

    def _topic(self, topic: str, ros_type: str) -> tuple[Any, type]:
        from cyclonedds.topic import Topic

        from benchbot_robot_ros2.msgs import dds_topic, message_class

        cls = message_class(ros_type)
        name = dds_topic(topic)
        with self._lock:
            if name not in self._topics:
                self._topics[name] = (Topic(self.participant, name, cls), cls)
            existing, existing_cls = self._topics[name]
        if existing_cls is not cls:
            raise ValueError(f"topic {topic} is already used with type {existing_cls.__name__}, not {ros_type}")
        return existing, cls

    def publisher(self, topic: str, ros_type: str, *, latched: bool = False) -> Publisher:
        from cyclonedds.core import Policy, Qos
        from cyclonedds.pub import DataWriter

        dds_topic_obj, cls = self._topic(topic, ros_type)
        qos = Qos(
            Policy.Reliability.Reliable(max_blocking_time=100_000_000),
            Policy.History.KeepLast(1 if latched else 10),
            Policy.Durability.TransientLocal if latched else Policy.Durability.Volatile,
            Policy.DataRepresentation(use_cdrv0_representation=True),
            Policy.Userdata(data=type_hash_user_data(ros_type)),
        )
        writer = DataWriter(self.participant, dds_topic_obj, qos=qos)
        self._keep.append(writer)
        with self._lock:
            self.writer_gids.append(writer.guid.bytes)
        self._announce()
        return _CyclonePublisher(writer, cls)

    def subscribe(self, topic: str, ros_type: str, callback: Callable[[Any], None], *, latched: bool = False,
                  reliable: bool = False) -> Any:
        from cyclonedds.core import Listener, Policy, Qos
        from cyclonedds.sub import DataReader

        dds_topic_obj, cls = self._topic(topic, ros_type)
        transport = self
        taking = threading.Lock()  # one thread at a time takes and delivers this reader's samples, in order

        def deliver(reader: Any) -> int:
            delivered = 0
            for _ in range(64):  # bounded: a flood cannot pin this thread
                try:
                    samples = reader.take(N=16)
                except Exception as exc:  # noqa: BLE001 - undecodable sample(s): dropped, counted
                    transport.errors += 1
                    transport.last_error = f"cannot decode a {ros_type} on {topic}: {exc!r}"
                    return delivered
                if not samples:
                    return delivered
                for sample in samples:
                    if isinstance(sample, cls):
                        transport._guard(callback, sample)
                        delivered += 1
            return delivered

        def on_data_available(reader: Any) -> None:
            with taking:
                deliver(reader)

        def poll(reader: Any) -> int:
            if not taking.acquire(blocking=False):  # the listener is delivering them now
                return 0
            try:
                return deliver(reader)
            finally:
                taking.release()

        policies = [
            Policy.Reliability.Reliable(max_blocking_time=100_000_000) if (reliable or latched) else Policy.Reliability.BestEffort,
            Policy.History.KeepLast(10),
            Policy.Durability.TransientLocal if latched else Policy.Durability.Volatile,
            Policy.DataRepresentation(use_cdrv0_representation=True, use_xcdrv2_representation=True),
            Policy.Userdata(data=type_hash_user_data(ros_type)),
        ]
        reader = DataReader(self.participant, dds_topic_obj, qos=Qos(*policies),
                            listener=Listener(on_data_available=on_data_available))
        self._keep.append(reader)
        with self._lock:
            self._pollers.append((topic, reader, poll))
        with self._lock:
            self.reader_gids.append(reader.guid.bytes)
        self._announce()
        on_data_available(reader)  # samples that arrived while the reader was being built (latched topics)
        return reader

    def poll(self, topics: Iterable[str] | None = None) -> int:
        """:meth:`Transport.poll`: takes each reader's queued samples (``DataReader.take``) and delivers them on this
        thread, unless the listener thread is delivering that reader's samples at this moment."""
        wanted = None if topics is None else set(topics)
        with self._lock:
            pollers = [p for p in self._pollers if wanted is None or p[0] in wanted]
        delivered = 0
        for _, reader, poll in pollers:
            try:
                delivered += poll(reader)
            except Exception:  # noqa: BLE001 - a reader deleted by close() meanwhile: nothing to deliver
                pass
        return delivered

    def close(self) -> None:
        """Delete the readers, writers, topics and the participant. The readers' listeners are removed first, on
        this thread: Cyclone DDS waits for a callback in progress to finish, and none starts afterwards. Otherwise a
        listener thread could drop the last reference to its own reader (cyclonedds hands the callback a strong
        reference) and delete it from inside its own callback, which never returns (seen as a hang in close)."""
        from cyclonedds.sub import DataReader

        for entity in self._keep:
            if isinstance(entity, DataReader):
                try:
                    entity.set_listener(None)
                except Exception:  # noqa: BLE001 - an entity already deleted with its participant: nothing to stop
                    pass
        with self._lock:
            self._pollers.clear()
        self._keep.clear()
        self._topics.clear()
        self._discovery = None
        self.participant = None


class _RclpyPublisher(Publisher):
    def __init__(self, pub: Any) -> None:
        self.pub = pub

    def publish(self, msg: Any) -> None:
        self.pub.publish(msg)


class RclpyTransport(Transport):
    """:class:`Transport` over an ``rclpy`` node (its own context, spun on a daemon thread).

    A message type whose ROS 2 package is not installed (the ``ros-jazzy-*`` PyPI wheels have no ``tf2_msgs``, so
    no ``/tf``) goes through a Cyclone DDS participant of this process instead (:class:`CycloneTransport`, the node
    ``<node_name>_cyclonedds``, same domain and network), said once in the log and listed in
    :attr:`via_cyclonedds`; Fast DDS and Cyclone DDS interoperate on loopback (docs/ros2.md). A sourced ROS 2
    install has every package, and then everything goes through rclpy.

    Args:
        domain_id: ROS_DOMAIN_ID of the node.
        network: ``loopback`` sets ``CYCLONEDDS_URI`` (rmw_cyclonedds_cpp) and ``FASTRTPS_DEFAULT_PROFILES_FILE``
            (rmw_fastrtps_cpp, Jazzy's default) to loopback-only configurations unless they are set already
            (:func:`configure_network`); ``system`` leaves them.
        node_name: the node's name.

    Attributes:
        via_cyclonedds: the types (``pkg/msg/Name``) sent and received through Cyclone DDS.

    Raises:
        ImportError: rclpy is not importable, or a message package is missing and the type is not one Cyclone DDS
            carries here. ValueError: an invalid ``node_name``.
    """

    name = "rclpy"

    def __init__(self, domain_id: int = 0, network: str = "loopback", node_name: str = DEFAULT_NODE_NAME) -> None:
        super().__init__()
        configure_network(network)
        check_node_name(node_name)
        self.domain_id, self.network, self.node_name = int(domain_id), network, node_name
        self._fallback: CycloneTransport | None = None
        self.via_cyclonedds: set[str] = set()
        self._handled = 0  # rclpy subscription callbacks run so far (either thread)
        import rclpy
        from rclpy.executors import SingleThreadedExecutor

        self._rclpy = rclpy
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=int(domain_id))
        self.node = rclpy.create_node(node_name, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._stop = threading.Event()
        self._spinning = threading.Lock()  # one thread at a time runs the executor (the spin thread, or poll())
        self._topics: dict[str, str] = {}  # topic -> "rclpy" or "cyclonedds": who delivers it
        self._thread = threading.Thread(target=self._spin, name="benchbot-rclpy", daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while not self._stop.is_set() and self._rclpy.ok(context=self.context):
            try:
                with self._spinning:
                    self.executor.spin_once(timeout_sec=0.05)
            except Exception as exc:  # noqa: BLE001
                self.errors += 1
                self.last_error = repr(exc)

    def poll(self, topics: Iterable[str] | None = None) -> int:
        """:meth:`Transport.poll`: the Cyclone DDS participant's queued samples (:meth:`CycloneTransport.poll`), and
        the callbacks rclpy has ready (``spin_once`` without waiting, up to 64), run here unless the spinning thread
        holds the executor: it is then waiting for messages or delivering them itself. rclpy runs whatever callback
        is ready first, so this may deliver other topics' messages too (returned as the count)."""
        wanted = None if topics is None else list(topics)
        delivered = self._fallback.poll(wanted) if self._fallback is not None else 0
        if wanted is not None and not any(self._topics.get(t) == "rclpy" for t in wanted):
            return delivered
        if not self._spinning.acquire(blocking=False):
            return delivered
        try:
            idle = 0
            for _ in range(64):
                before = self._handled
                self.executor.spin_once(timeout_sec=0.0)
                if self._handled > before:
                    delivered, idle = delivered + self._handled - before, 0
                else:  # the executor's list of ready callbacks ran out: one more wait tells whether more came
                    idle += 1
                    if idle >= 2:
                        break
        except Exception as exc:  # noqa: BLE001 - as on the spinning thread: counted, never raised
            self.errors += 1
            self.last_error = repr(exc)
        finally:
            self._spinning.release()
        return delivered

    @staticmethod
    def _cls(ros_type: str) -> type:
        from benchbot_robot_ros2.naming import normalise_type

        pkg, _, name = normalise_type(ros_type).split("/")
        return getattr(importlib.import_module(f"{pkg}.msg"), name)

    def _cyclone(self, ros_type: str) -> "CycloneTransport | None":
        """The Cyclone DDS participant for ``ros_type`` when its ROS 2 package is not installed and Cyclone DDS
        carries it; ``None`` when rclpy has it.

        Raises:
            ImportError: the package is missing and the type is not one of :data:`~benchbot_robot_ros2.msgs.TYPES`.
        """
        from benchbot_robot_ros2.msgs import TYPES
        from benchbot_robot_ros2.naming import normalise_type

        name = normalise_type(ros_type)
        try:
            self._cls(name)
            return None
        except ModuleNotFoundError:
            if name not in TYPES:
                raise
        if self._fallback is None:
            log.warning("rclpy has no %s package here: %s goes through Cyclone DDS (node %s_cyclonedds)",
                        name.split("/")[0], name, self.node_name)
            self._fallback = CycloneTransport(self.domain_id, self.network, f"{self.node_name}_cyclonedds")
        self.via_cyclonedds.add(name)
        return self._fallback

    def message(self, ros_type: str) -> Any:
        other = self._cyclone(ros_type)
        return other.message(ros_type) if other is not None else self._cls(ros_type)()

    def _qos(self, latched: bool, reliable: bool, publisher: bool) -> Any:
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

        rel = ReliabilityPolicy.RELIABLE if (publisher or reliable or latched) else ReliabilityPolicy.BEST_EFFORT
        dur = DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE
        return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1 if (latched and publisher) else 10,
                          reliability=rel, durability=dur)

    def publisher(self, topic: str, ros_type: str, *, latched: bool = False) -> Publisher:
        other = self._cyclone(ros_type)
        if other is not None:
            return other.publisher(topic, ros_type, latched=latched)
        return _RclpyPublisher(self.node.create_publisher(self._cls(ros_type), topic, self._qos(latched, True, True)))

    def subscribe(self, topic: str, ros_type: str, callback: Callable[[Any], None], *, latched: bool = False,
                  reliable: bool = False) -> Any:
        other = self._cyclone(ros_type)
        if other is not None:
            self._topics[topic] = "cyclonedds"
            return other.subscribe(topic, ros_type, lambda m: self._guard(callback, m), latched=latched,
                                   reliable=reliable)
        self._topics[topic] = "rclpy"

        def handle(msg: Any) -> None:
            self._handled += 1
            self._guard(callback, msg)

        return self.node.create_subscription(self._cls(ros_type), topic, handle, self._qos(latched, reliable, False))

    def close(self) -> None:
        """Stop the spinning thread (joined: a thread left inside rclpy at interpreter exit aborts the process),
        then the executor, the node and the context; and the Cyclone DDS participant of missing message packages."""
        self._stop.set()
        if self._thread is not threading.current_thread():
            self._thread.join(timeout=5)
        try:
            self.executor.shutdown()
            self.node.destroy_node()
            self._rclpy.shutdown(context=self.context)
        except Exception:  # noqa: BLE001
            pass
        if self._fallback is not None:
            self._fallback.close()


def make_transport(kind: str = "auto", domain_id: int = 0, network: str = "loopback",
                   node_name: str = DEFAULT_NODE_NAME) -> Transport:
    """The transport ``kind``: ``'auto'`` (rclpy when importable, else Cyclone DDS), ``'rclpy'`` or
    ``'cyclonedds'``, as the ROS 2 node ``node_name``.

    Raises:
        benchbot.core.errors.BackendError: the transport cannot be started (names the missing package).
    """
    from benchbot.core.errors import BackendError

    if kind not in ("auto", "rclpy", "cyclonedds"):
        raise BackendError(f"unknown ROS 2 transport {kind!r}", "use ros2.transport: auto, rclpy or cyclonedds")
    try:
        if kind == "rclpy" or (kind == "auto" and rclpy_available()):
            return RclpyTransport(domain_id, network, node_name)
        return CycloneTransport(domain_id, network, node_name)
    except ImportError as exc:
        raise BackendError(f"ROS 2 transport {kind!r} cannot start: {exc}",
                           "source a ROS 2 Jazzy install for rclpy, or install the cyclonedds package") from exc
    except Exception as exc:  # noqa: BLE001 - DDS configuration errors etc.
        raise BackendError(f"ROS 2 transport {kind!r} cannot start: {exc!r}",
                           "check CYCLONEDDS_URI / ROS_DOMAIN_ID (domain ids 0..232)") from exc
