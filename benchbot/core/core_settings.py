"""The core's own settings: what one environment variable BenchBot reads is (:class:`Setting`), the table of those
the core, the client API and the CLI read (:data:`SETTINGS`), how a value is read (:func:`resolve`), and the readers
that check a value's text (:func:`whole_number`, :func:`positive_number`, :func:`one_of`, :func:`gpu_share`,
:func:`absolute_path`; :func:`benchbot.core.settings.value` applies them).

This module knows no plugin, so that the plugin manager can read ``BENCHBOT_DISABLE_PLUGINS`` through it; plugins
declare their own settings through the hook ``benchbot_settings``, and :mod:`benchbot.core.settings` reads both
(``settings.get``). Command-line flags and spec fields win over these where both exist (e.g. ``--address`` over
``BENCHBOT_SUPERVISOR_ADDRESS``); a setting only gives the value when nothing more specific does. An empty or blank
value counts as unset.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from typing import Any, Callable

#: The prefix of every variable of BenchBot's own (a plugin's other names are ``external``).
PREFIX = "BENCHBOT_"


@dataclass(frozen=True)
class Setting:
    """One environment variable that BenchBot or a plugin reads.

    Attributes:
        name: the variable, ``BENCHBOT_<WORDS>`` in upper case (digits and ``_`` allowed); another program's
            variable that BenchBot reads too (``ROS_DOMAIN_ID``, ``XDG_CACHE_HOME``) has no prefix and
            ``external=True``.
        default: the value when the variable is unset or blank, as text (``None``: no value).
        meaning: what it changes, in a phrase (``benchbot doctor`` shows it).
        owner: the part of BenchBot that reads it: ``core``, ``api``, ``cli``, or a plugin's entry-point name. For a
            plugin's settings the core writes the declaring plugin's name here, whatever the plugin gave.
        secret: its value is shown as ``***`` by ``benchbot doctor`` and never recorded.
        reader: turns the text into the value its reader uses (``int``, a choice), raising ``ValueError`` with a
            short reason for text that is no valid value; ``None``: the text is the value.
            ``benchbot.core.settings.value`` applies it, and ``benchbot doctor`` marks a value it rejects.
        external: another program's variable (no ``BENCHBOT_`` prefix needed).
    """

    name: str
    default: str | None
    meaning: str
    owner: str = ""
    secret: bool = False
    reader: Callable[[str], Any] | None = field(default=None, compare=False, repr=False)
    external: bool = False


# Readers for Setting.reader: each takes the text and raises ValueError with a short reason (``benchbot.core.settings``
# names them too).


def whole_number(low: int, high: int | None = None):
    """A reader of a whole number from ``low`` to ``high`` (``None``: no upper bound), giving an ``int``.

    Raises (the reader):
        ValueError: ``"not a whole number from LOW to HIGH"`` (``"not a whole number of at least LOW"``).
    """
    bounds = f"from {low} to {high}" if high is not None else f"of at least {low}"

    def read(text: str) -> int:
        try:
            number = int(text)
        except ValueError:
            raise ValueError(f"not a whole number {bounds}") from None
        if number < low or (high is not None and number > high):
            raise ValueError(f"not a whole number {bounds}")
        return number

    read.__doc__ = f"A whole number {bounds}."
    return read


def positive_number(text: str) -> float:
    """A reader of a finite number above 0 (a speed, a scale), giving a ``float``.

    Raises:
        ValueError: ``"not a number above 0"``.
    """
    try:
        number = float(text)
    except ValueError:
        number = math.nan
    if not 0.0 < number < math.inf:
        raise ValueError("not a number above 0")
    return number


def one_of(*choices: str):
    """A reader accepting ``choices`` (case and surrounding blanks ignored) and giving the choice in lower case.

    Raises (the reader):
        ValueError: ``"not one of a, b, c"``.
    """
    def read(text: str) -> str:
        word = text.strip().lower()
        if word not in choices:
            raise ValueError(f"not one of {', '.join(choices)}")
        return word

    read.__doc__ = f"One of {', '.join(choices)} (case ignored)."
    return read


def gpu_share(text: str) -> float:
    """A reader of a share of a GPU as Ray's ``num_gpus`` takes it: a number from 0.0001 (Ray's finest share) to 1,
    or a whole number of GPUs above 1, giving a ``float``.

    Raises:
        ValueError: ``"not a share of a GPU: ..."`` (what is valid, in a phrase).
    """
    try:
        share = float(text)
    except ValueError:
        share = math.nan
    if not (0.0001 <= share <= 1 or (1 < share < math.inf and share.is_integer())):
        raise ValueError("not a share of a GPU: a number from 0.0001 to 1 (0.0625: 16 episodes per GPU), or a whole "
                         "number of GPUs")
    return share


def absolute_path(text: str) -> str:
    """A reader of an absolute path (``/dev/shm``), giving it as written; whether it exists is for its user to check
    (it may name a folder inside a sandbox).

    Raises:
        ValueError: ``"not an absolute path (one starting with /)"``.
    """
    if not os.path.isabs(text):
        raise ValueError("not an absolute path (one starting with /)")
    return text


#: The core's settings (the core, the client API, the CLI), in the order ``benchbot doctor`` shows them; plugins'
#: settings follow them there, in plugin order.
SETTINGS: tuple[Setting, ...] = (
    Setting("BENCHBOT_DATA_DIR", None, "data directory (installed content packs); else $XDG_DATA_HOME/benchbot, "
            "else ~/.local/share/benchbot", "core"),
    Setting("XDG_DATA_HOME", None, "base of the data directory when BENCHBOT_DATA_DIR is unset", "core",
            external=True),
    Setting("BENCHBOT_CACHE_DIR", None, "cache directory (the simulator's built scenes; hidden from sandboxed "
            "solutions); else $XDG_CACHE_HOME/benchbot, else ~/.cache/benchbot", "core"),
    Setting("XDG_CACHE_HOME", None, "base of the cache directory when BENCHBOT_CACHE_DIR is unset", "core",
            external=True),
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
            "(containers set it; sandboxes where the backend made no frames folder); a value other than 0 or 1 is "
            "taken as 0", "api", reader=one_of("0", "1")),
    Setting("BENCHBOT_SHARED_MEMORY_DIR", "/dev/shm", "the folder where a client opens its shared-memory segments "
            "(a sandbox sets it to its read-only frames folder); where it is no folder the client can read, frames "
            "come in the HTTP reply and the client's shared_memory_error says why", "api", reader=absolute_path),
    Setting("BENCHBOT_SANDBOX_DISPLAY", "1", "0: sandboxed solutions get no display (they draw off screen, "
            "MPLBACKEND=Agg); otherwise your X11 or Wayland display is passed into the sandbox", "core"),
    Setting("BENCHBOT_BACKEND_CHECK_TIMEOUT_S", "1", "seconds `benchbot submit` gives a backend to accept a "
            "connection before running anything", "cli"),
    Setting("BENCHBOT_BACKEND_START_WAIT_S", "60", "seconds `benchbot submit` waits for a backend that accepted "
            "the connection but is still starting", "cli"),
    Setting("BENCHBOT_INSTALLER", None, "uv or pip: the installer of `benchbot install` (default: uv when on "
            "PATH)", "cli"),
    Setting("BENCHBOT_SERVICE", "auto", "auto: `batch` and `run` build the simulator in the resident simulator service, "
            "started on first use; off: in the command's own process, as --no-service (docs/service.md)", "cli"),
    Setting("BENCHBOT_SERVICE_IDLE_S", "900", "seconds without an episode after which the simulator service stops "
            "by itself (read when it starts)", "cli"),
    Setting("BENCHBOT_RAY_GPUS_PER_EPISODE", "0.0625", "the share of a GPU a Ray batch's episode on a GPU "
            "(--arch cuda) reserves on its node: Ray places episodes by GPU (docs/cluster.md); 0.0001 to 1, or a "
            "whole number", "core", reader=gpu_share),
    Setting("BENCHBOT_MANIFEST_LOCAL", None, "1: a batch's manifest keeps the host name and absolute paths (by "
            "default it names no host, and paths are ~/... or $RUN_DIR/...)", "core"),
)

BY_NAME: dict[str, Setting] = {s.name: s for s in SETTINGS}


def resolve(setting: Setting) -> tuple[str | None, str]:
    """``(value, source)`` of ``setting``: the environment variable, stripped, when set and not blank
    (``'environment'``), else its default (``'default'``, or ``'unset'`` when it has none)."""
    given = os.environ.get(setting.name, "").strip()
    if given:
        return given, "environment"
    return setting.default, "default" if setting.default is not None else "unset"


def core_get(name: str) -> str | None:
    """The value of the core's setting ``name`` (:func:`resolve`), for the modules below the plugin manager.

    Raises:
        KeyError: ``name`` is not in :data:`SETTINGS`.
    """
    return resolve(BY_NAME[name])[0]
