"""BenchBot's settings from the environment: every environment variable that BenchBot and its first-party plugins
read, in one table, read through one function (:func:`get`), shown with its effective value and where the value
came from by ``benchbot doctor`` (:func:`effective`).

Command-line flags and spec fields win over these where both exist (e.g. ``--address`` over
``BENCHBOT_SUPERVISOR_ADDRESS``); a setting only gives the value when nothing more specific does. An empty or blank
value counts as unset.
"""

from __future__ import annotations

import os
from dataclasses import dataclass


@dataclass(frozen=True)
class Setting:
    """One environment variable: its ``name``, its ``default`` when unset (``None``: no value), what it means, and
    the part of BenchBot that reads it (``owner``: ``core``, ``api``, ``cli``, or a plugin's name)."""

    name: str
    default: str | None
    meaning: str
    owner: str
    secret: bool = False


#: Every setting, in the order ``benchbot doctor`` shows them.
SETTINGS: tuple[Setting, ...] = (
    Setting("BENCHBOT_DATA_DIR", None, "data directory (installed content packs); else $XDG_DATA_HOME/benchbot, "
            "else ~/.local/share/benchbot", "core"),
    Setting("XDG_DATA_HOME", None, "base of the data directory when BENCHBOT_DATA_DIR is unset", "core"),
    Setting("BENCHBOT_CACHE_DIR", None, "cache directory (the simulator's built scenes; hidden from sandboxed "
            "solutions); else $XDG_CACHE_HOME/benchbot, else ~/.cache/benchbot", "core"),
    Setting("XDG_CACHE_HOME", None, "base of the cache directory when BENCHBOT_CACHE_DIR is unset", "core"),
    Setting("BENCHBOT_RESULT_LOCATION", "/tmp/benchbot_result", "the results file a solution writes (the "
            "original's fixed path by default)", "api"),
    Setting("BENCHBOT_SUPERVISOR_ADDRESS", "http://127.0.0.1:10000/", "the backend a solution's BenchBot() and "
            "`benchbot submit` connect to (--address wins)", "api"),
    Setting("BENCHBOT_TOKEN", None, "the backend's access token, sent by clients (docs/security.md)", "api",
            secret=True),
    Setting("BENCHBOT_CA_FILE", None, "PEM certificate authorities for an https:// backend", "api"),
    Setting("BENCHBOT_CLIENT_ID", None, "names one solution's connections as one owner of the episode (else a "
            "random id per client); `benchbot submit` sets it for the solution it runs", "api"),
    Setting("BENCHBOT_DEBUG", None, "1: print the traceback behind a one-line error", "cli"),
    Setting("BENCHBOT_DISABLE_PLUGINS", None, "comma list of plugins (entry-point names) not to load", "core"),
    Setting("BENCHBOT_ONLY_PLUGINS", None, "comma list of the only plugins to load (the tests set it)", "core"),
    Setting("BENCHBOT_SHARED_MEMORY", "1", "0: clients take frames in the HTTP reply, never through /dev/shm "
            "(sandboxes and containers set it)", "api"),
    Setting("BENCHBOT_SANDBOX_DISPLAY", "1", "0: sandboxed solutions get no display (they draw off screen, "
            "MPLBACKEND=Agg); otherwise your X11 or Wayland display is passed into the sandbox", "core"),
    Setting("BENCHBOT_BACKEND_CHECK_TIMEOUT_S", "1", "seconds `benchbot submit` gives a backend to accept a "
            "connection before running anything", "cli"),
    Setting("BENCHBOT_BACKEND_START_WAIT_S", "60", "seconds `benchbot submit` waits for a backend that accepted "
            "the connection but is still starting", "cli"),
    Setting("BENCHBOT_INSTALLER", None, "uv or pip: the installer of `benchbot install` (default: uv when on "
            "PATH)", "cli"),
    Setting("BENCHBOT_SIM_STYLE", "furnished", "scene style of environments naming none: furnished or "
            "primitives", "sim_taichi"),
    Setting("BENCHBOT_TAICHI_ARCH", "cpu", "Taichi arch of the simulator: cpu, gpu or cuda (--arch wins)",
            "sim_taichi"),
    Setting("BENCHBOT_TAICHI_THREADS", None, "CPU threads per simulator process (default: one per core; batch "
            "workers set it)", "sim_taichi"),
    Setting("BENCHBOT_TAICHI_FULL_POSITIONS", None, "1: the simulator's kernels keep Taichi's full source excerpts "
            "in their debug information (slower start; for changing the kernels)", "sim_taichi"),
    Setting("BENCHBOT_MANIFEST_LOCAL", None, "1: a batch's manifest keeps the host name and absolute paths (by "
            "default it names no host, and paths are ~/... or $RUN_DIR/...)", "core"),
    Setting("BENCHBOT_WORLDS_KEY_FILE", None, "the host's key of the held-out test split of procedural homes (only "
            "a host holding it can build them); else <data dir>/worlds/test_split.key, made by `benchbot worlds "
            "key`", "worlds"),
    Setting("ROS_DOMAIN_ID", "0", "DDS domain of ROS 2 robots and `benchbot ros2 serve-sim`", "robot_ros2"),
    Setting("CYCLONEDDS_URI", None, "Cyclone DDS configuration (default: discovery on loopback only)",
            "robot_ros2"),
    Setting("FASTRTPS_DEFAULT_PROFILES_FILE", None, "Fast DDS profile of rclpy on rmw_fastrtps_cpp (default: "
            "benchbot_robot_ros2's fastdds_loopback.xml, UDP on 127.0.0.1 only)", "robot_ros2"),
    Setting("BENCHBOT_ROS2_TIME_SCALE", None, "simulated seconds per wall second of ROS 2 robots (the robot "
            "spec's time_scale by default)", "robot_ros2"),
)


def all_settings() -> tuple[Setting, ...]:
    """:data:`SETTINGS` and, after them, every limit of :mod:`benchbot.core.limits` that a variable changes (its
    default in its unit, owner ``core (limits)``): the one table of the variables BenchBot reads, as ``benchbot
    doctor`` shows it. Limits are read by :meth:`benchbot.core.limits.Limit.value`, which checks their values."""
    from benchbot.core import limits

    return SETTINGS + tuple(Setting(limit.env, limit.describe(limit.default), limit.meaning, "core (limits)")
                            for limit in limits.all_limits().values() if limit.env)


_BY_NAME = {s.name: s for s in SETTINGS}


def get(name: str) -> str | None:
    """The value of setting ``name``: the environment variable, stripped, when set and not blank; else its
    default (``None`` when it has none).

    Raises:
        KeyError: ``name`` is not in :data:`SETTINGS` (a programming error: add the setting there first).
    """
    return _resolve(_BY_NAME[name])[0]


def _resolve(setting: Setting) -> tuple[str | None, str]:
    """``(value, source)`` of ``setting``: the environment variable, stripped, when set and not blank
    (``'environment'``), else its default (``'default'``, or ``'unset'`` when it has none)."""
    given = os.environ.get(setting.name, "").strip()
    if given:
        return given, "environment"
    return setting.default, "default" if setting.default is not None else "unset"


def default(name: str) -> str | None:
    """The default of setting ``name`` (its value when the variable is unset).

    Raises:
        KeyError: ``name`` is not in :data:`SETTINGS`.
    """
    return _BY_NAME[name].default


def source(name: str) -> str:
    """Where :func:`get`'s value comes from: ``'environment'``, ``'default'`` or ``'unset'`` (no default).

    Raises:
        KeyError: ``name`` is not in :data:`SETTINGS`.
    """
    return _resolve(_BY_NAME[name])[1]


def effective() -> list[dict]:
    """Every setting and limit (:func:`all_settings`) as ``{'name', 'value', 'source', 'owner', 'meaning'}``: the
    value as the environment gives it, else the default (secret values shown as ``'***'``), and where it came from
    (``'environment'``, ``'default'`` or ``'unset'``)."""
    rows = []
    for s in all_settings():
        value, where = _resolve(s)
        rows.append({"name": s.name, "value": "***" if (s.secret and value) else value, "source": where,
                     "owner": s.owner, "meaning": s.meaning})
    return rows
