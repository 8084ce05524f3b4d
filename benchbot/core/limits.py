"""Every resource limit of BenchBot, in one place: what one request, one input file or one child process may cost.

Each limit is a :class:`Limit` with its default and the environment variable that overrides it; values are read
from the environment when used (:meth:`Limit.value`), so a variable set for one command applies to it alone.

==========================  =======================  ===================================  ==============================
limit                       default                  environment variable                 what the user sees past it
==========================  =======================  ===================================  ==============================
**server, episode**
MAX_REQUEST_BYTES           1 MiB                    BENCHBOT_MAX_REQUEST_BYTES           HTTP 413 (body not read)
MAX_OBSERVATION_NAMES       64 names                 BENCHBOT_MAX_OBSERVATION_NAMES       HTTP 400
MAX_RESULTS_ARG_NUMBER      100000                   BENCHBOT_MAX_RESULTS_ARG_NUMBER      HTTP 400
MAX_RESULTS_REPLY_BYTES     8 MiB                    BENCHBOT_MAX_RESULTS_REPLY_BYTES     HTTP 400
RESULTS_FUNCTION_TIMEOUT_S  10 seconds               BENCHBOT_RESULTS_FUNCTION_TIMEOUT_S  HTTP 504
EPISODE_LEASE_S             60 seconds               BENCHBOT_EPISODE_LEASE_S             HTTP 409 to other clients
MAX_MOVE_DISTANCE_M         100 metres               BENCHBOT_MAX_MOVE_DISTANCE_M         HTTP 400
MAX_MOVE_ANGLE_DEG          360 degrees              BENCHBOT_MAX_MOVE_ANGLE_DEG          HTTP 400
MAX_CAMERA_SIDE             8192 pixels              (none: --camera-size)                usage error (exit 2)
**input files**
MAX_SPEC_BYTES              4 MiB                    BENCHBOT_MAX_SPEC_BYTES              spec error (exit 3)
MAX_RESULTS_BYTES           64 MiB                   BENCHBOT_MAX_RESULTS_BYTES           results error (exit 4)
MAX_ZIP_BYTES               256 MiB                  BENCHBOT_MAX_ZIP_BYTES               results error (exit 4)
MAX_ZIP_MEMBERS             10000 members            BENCHBOT_MAX_ZIP_MEMBERS             results error (exit 4)
MAX_NESTING_DEPTH           64 levels                BENCHBOT_MAX_NESTING_DEPTH           spec/results error (3/4)
**command-line counts**
MAX_REPEAT                  1000 repetitions         BENCHBOT_MAX_REPEAT                  usage error (exit 2)
MAX_BATCH_EPISODES          100000 episodes          BENCHBOT_MAX_BATCH_EPISODES          usage error (exit 2)
MAX_WORKERS                 256 workers              BENCHBOT_MAX_WORKERS                 usage error (exit 2)
MAX_RETRIES                 100 retries              BENCHBOT_MAX_RETRIES                 usage error (exit 2)
MAX_SEED                    4294967295               (none: --seed, 0 to 2**32 - 1)       usage error (exit 2)
MAX_GENERATED_HOMES         10000 homes              BENCHBOT_MAX_GENERATED_HOMES         usage error (exit 2)
MAX_HOME_INDEX              1000000000               (none: a generated home's index)     usage error (exit 2)
MAX_RENDER_SAMPLES          4096 samples             (none: sim render --spp, ...)        usage error (exit 2)
**child processes**
MAX_LOG_BYTES               16 MiB (0: no cap)       BENCHBOT_MAX_LOG_BYTES               log cut, with a last line
STOP_GRACE_S                5 seconds (0: no grace)  BENCHBOT_STOP_GRACE_S                SIGKILL after SIGTERM
SANDBOX_TMP_BYTES           1 GiB                    BENCHBOT_SANDBOX_TMP_BYTES           ENOSPC in the sandbox's /tmp
SANDBOX_MEMORY_BYTES        8 GiB                    BENCHBOT_SANDBOX_MEMORY_BYTES        episode ``resource_limit``
SANDBOX_PROCESSES           512 tasks                BENCHBOT_SANDBOX_PROCESSES           episode ``resource_limit``
SANDBOX_FILE_BYTES          1 GiB                    BENCHBOT_SANDBOX_FILE_BYTES          episode ``resource_limit``
SANDBOX_OUTPUTS_BYTES       4 GiB                    BENCHBOT_SANDBOX_OUTPUTS_BYTES       episode ``resource_limit``
SANDBOX_CPU_S               36000 seconds            BENCHBOT_SANDBOX_CPU_S               episode ``resource_limit``
RAY_EPISODE_BYTES           1 GiB                    BENCHBOT_RAY_EPISODE_BYTES           episode error, its log kept
**caches**
SCENE_CACHE_BYTES           4 GiB (0: no cache)      BENCHBOT_SCENE_CACHE_BYTES           oldest built scenes removed
==========================  =======================  ===================================  ==============================

Every error past a limit is one line naming the limit and how to raise it (:meth:`Limit.raise_hint`). A variable
that is not a valid value is a one-line :class:`~benchbot.core.errors.UsageError` naming it (exit 2), e.g.
``BENCHBOT_MAX_RESULTS_BYTES='lots' is not a positive whole number of bytes``. Byte limits accept a whole number
of bytes or one with a binary suffix (``512K``, ``64M``, ``1G``); a limit whose ``0`` has a meaning (no cap, no
grace) says so in the table, every other limit must be positive.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from benchbot.core.errors import UsageError

_SUFFIXES = {"K": 1 << 10, "M": 1 << 20, "G": 1 << 30}


@dataclass(frozen=True)
class Limit:
    """A bound with a default and the environment variable that overrides it.

    Attributes:
        default: the bound when the variable is unset or empty (in :attr:`unit`).
        env: the environment variable (``None``: not overridable).
        unit: a plural noun for messages (``"bytes"``, ``"seconds"``, ``"members"``; ``""``: a bare number). A
            ``"bytes"`` variable may carry a binary suffix ``K``/``M``/``G`` (``64M``).
        integer: the bound is a whole number (bytes, counts).
        zero_means: what ``0`` means where it is allowed (``"no cap"``); ``None``: the bound must be positive.
        meaning: what it bounds, in a phrase (``benchbot doctor`` shows it beside the settings).

    Raises:
        ValueError: a ``"bytes"`` limit without ``integer=True`` (a programming error, at import).
    """

    default: float
    env: str | None = None
    unit: str = ""
    integer: bool = False
    zero_means: str | None = None
    meaning: str = ""

    def __post_init__(self) -> None:
        if self.unit == "bytes" and not self.integer:
            raise ValueError("a byte limit is a whole number: pass integer=True")
        if self.env and not self.meaning:
            raise ValueError(f"limit {self.env} needs a meaning")

    def value(self) -> float:
        """The bound now: ``$env`` when set and non-empty, else :attr:`default` (an ``int`` for :attr:`integer`
        limits, else a ``float``).

        Raises:
            UsageError: ``$env`` is not a finite number (whole for :attr:`integer` limits, with an optional ``K``/
                ``M``/``G`` suffix for bytes) that is positive, or 0 where :attr:`zero_means` allows it.
        """
        raw = os.environ.get(self.env, "").strip() if self.env else ""
        if not raw:
            return self.default
        return self.parse(raw, self.env)

    def parse(self, raw: str, name: str, hint: str | None = None) -> float:
        """``raw`` as a value of this limit (as :meth:`value` reads its variable: ``4G``, ``600``).

        Raises:
            UsageError: ``raw`` is not a valid value; the message names it as ``name=raw`` (``hint``: the fix; default:
                how to set the variable).
        """
        number = self._parse(raw.strip())
        if number is None or not (number > 0 or (number == 0 and self.zero_means is not None)):
            raise UsageError(f"{name}={raw!r} is not {self.kind()}", hint or self._fix_hint())
        return number

    def _parse(self, raw: str) -> float | None:
        scale = 1
        if self.unit == "bytes" and raw[-1:].upper() in _SUFFIXES:
            raw, scale = raw[:-1], _SUFFIXES[raw[-1].upper()]
        try:
            number = int(raw) * scale if self.integer else float(raw)
        except ValueError:  # not a number, or an integer of more than sys.get_int_max_str_digits() digits
            return None
        return number if math.isfinite(number) else None

    def kind(self) -> str:
        """What a valid value is, for messages: ``a positive whole number of bytes``, ``a number of seconds ≥ 0``."""
        number = "whole number" if self.integer else "number"
        of_unit = f" of {self.unit}" if self.unit else ""
        if self.zero_means is not None:
            return f"a {number}{of_unit} ≥ 0"
        return f"a positive {number}{of_unit}"

    def _fix_hint(self) -> str:
        zero = f" (0: {self.zero_means})" if self.zero_means is not None else ""
        return (f"e.g. {self.env}={self.example(2 * self.default)}{zero}, or unset it for the default "
                f"({self.describe(self.default)})")

    def describe(self, number: float | None = None) -> str:
        """``number`` (default: :meth:`value`) in this limit's unit, for messages: ``64 MiB``, ``10000 members``,
        ``10 seconds``, ``0 (no cap)``.

        Raises:
            UsageError: ``number`` is None and ``$env`` is not a valid value (see :meth:`value`).
        """
        number = self.value() if number is None else number
        if number == 0 and self.zero_means is not None:
            return f"0 ({self.zero_means})"
        if self.unit == "bytes":
            return human_bytes(int(number))
        unit = self.unit[:-1] if number == 1 and self.unit.endswith("s") else self.unit
        return f"{_plain(number)} {unit}".rstrip()

    def example(self, number: float) -> str:
        """``number`` written as a value of this limit's variable (``8M`` for 8 MiB of bytes, ``20``)."""
        if self.unit == "bytes" and number >= 1 << 20:
            return f"{max(1, int(number) >> 20)}M"
        return _plain(number)

    def raise_hint(self) -> str:
        """``set BENCHBOT_X to raise it``: how to raise the limit, to end a one-line message (in parentheses)."""
        return f"set {self.env} to raise it" if self.env else "a fixed limit"

    def hint(self) -> str:
        """How to raise the limit, for an error's hint: ``raise the limit with the environment variable
        BENCHBOT_X (e.g. BENCHBOT_X=8M)`` (twice its current value); ``the limit is fixed`` without a variable.

        Raises:
            UsageError: ``$env`` is not a valid value (see :meth:`value`).
        """
        if not self.env:
            return "the limit is fixed"
        return f"raise the limit with the environment variable {self.env} (e.g. {self.env}=" \
               f"{self.example(2 * self.value())})"


def human_bytes(number: int) -> str:
    """``1536`` → ``1.5 KiB``; exact powers print without decimals (``64 MiB``); under 1 KiB: ``300 bytes``."""
    for unit, size in (("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if number >= size:
            value = number / size
            return f"{value:.0f} {unit}" if value == int(value) else f"{value:.1f} {unit}"
    return f"{number} bytes"


def _plain(number: float) -> str:
    """``100000.0`` → ``100000``, ``1.5`` → ``1.5`` (never ``1e+05``)."""
    return str(int(number)) if number == int(number) else f"{number:g}"


def all_limits() -> dict[str, Limit]:
    """Every limit of this module by its name (``{'MAX_REQUEST_BYTES': Limit(...), ...}``), in definition order."""
    return {name: value for name, value in globals().items() if isinstance(value, Limit)}


# --- backend server and episode ----------------------------------------------------------------------------------

MAX_REQUEST_BYTES = Limit(1 << 20, "BENCHBOT_MAX_REQUEST_BYTES", "bytes", integer=True,
                          meaning="bytes of one request body to the backend")
"""Request bodies larger than this are answered 413 without being read (``Content-Length`` is checked first; a
chunked body is cut off as soon as it passes the bound)."""

MAX_OBSERVATION_NAMES = Limit(64, "BENCHBOT_MAX_OBSERVATION_NAMES", "names", integer=True,
                              meaning="observation names in one native step")
"""Observation names one native step may ask for (a task observes fewer than ten); past it: 400."""

MAX_RESULTS_ARG_NUMBER = Limit(100_000, "BENCHBOT_MAX_RESULTS_ARG_NUMBER",
                               meaning="the largest number in a results function's arguments")
"""Every number in a results function's ``args``/``kwargs`` — and every string that reads as a number — must lie
within ± this. The server cannot tell which argument is a count (``create_object(num_classes)``), so one bound
covers counts and coordinates alike (map coordinates are metres; label probabilities lie in [0, 1]); past it: 400."""

MAX_RESULTS_REPLY_BYTES = Limit(8 << 20, "BENCHBOT_MAX_RESULTS_REPLY_BYTES", "bytes", integer=True,
                                meaning="bytes of a results function's reply")
"""The JSON reply of one results-function call; past it: 400."""

RESULTS_FUNCTION_TIMEOUT_S = Limit(10.0, "BENCHBOT_RESULTS_FUNCTION_TIMEOUT_S", "seconds",
                                   meaning="seconds a results function may run")
"""A results function still running after this answers 504; results functions run one at a time on their own
thread, never on the server's event loop or the backend thread."""

EPISODE_LEASE_S = Limit(60.0, "BENCHBOT_EPISODE_LEASE_S", "seconds",
                        meaning="idle seconds before another client may take the episode")
"""An episode belongs to the client that started it until that client releases it (``/robot/release``) or sends
no request for this long; until then other clients get 409 (docs/protocol.md, "One client at a time")."""

MAX_MOVE_DISTANCE_M = Limit(100.0, "BENCHBOT_MAX_MOVE_DISTANCE_M", "metres", meaning="metres of one move_distance")
"""``move_distance``'s ``distance`` must lie within ± this (metres); past it: 400."""

MAX_MOVE_ANGLE_DEG = Limit(360.0, "BENCHBOT_MAX_MOVE_ANGLE_DEG", "degrees", meaning="degrees of one move_angle")
"""``move_angle``'s ``angle`` must lie within ± this (degrees); past it: 400."""

MAX_CAMERA_SIDE = Limit(8192, None, "pixels", integer=True, meaning="pixels of a camera side (--camera-size)")
"""``--camera-size WxH``: each side at most this many pixels (a larger camera fails at its first observation)."""

# --- input files (benchbot.core.safe_load) ------------------------------------------------------------------------

MAX_SPEC_BYTES = Limit(4 << 20, "BENCHBOT_MAX_SPEC_BYTES", "bytes", integer=True,
                       meaning="bytes of a spec file of a pack or plugin")
"""Largest spec file (YAML or JSON: task, robot, environment, format, evaluator, example, batch, ground truth,
pack manifest) read by the registry or ``benchbot install``. The largest shipped ground truth is ~110 KB."""

MAX_RESULTS_BYTES = Limit(64 << 20, "BENCHBOT_MAX_RESULTS_BYTES", "bytes", integer=True,
                          meaning="bytes of a results file, or of one zip member decompressed")
"""Largest results file, or results member of a zip archive after decompression, read by ``benchbot eval``.
A result of 1000 objects over 30 classes is under 1 MB; the parsed file takes roughly 4x its size in memory."""

MAX_ZIP_BYTES = Limit(256 << 20, "BENCHBOT_MAX_ZIP_BYTES", "bytes", integer=True,
                      meaning="bytes of a zip archive, on disk and decompressed")
"""Largest zip archive of results: both its size on disk and the sum of its members' decompressed sizes."""

MAX_ZIP_MEMBERS = Limit(10_000, "BENCHBOT_MAX_ZIP_MEMBERS", "members", integer=True,
                        meaning="entries in one zip archive")
"""Most entries (files and folders) in one zip archive of results."""

MAX_NESTING_DEPTH = Limit(64, "BENCHBOT_MAX_NESTING_DEPTH", "levels", integer=True,
                          meaning="nesting of lists and objects in specs and results")
"""Deepest nesting of lists/objects in a spec or results file (a results file needs 6 levels)."""

# --- command-line counts (benchbot.cli.options.check_count) -------------------------------------------------------
# Every flag that counts something is bounded, and checked before anything proportional to it is made: a mistyped
# `--repeat 99999999999999999999` is a one-line usage error naming the flag and its maximum, not a batch plan that
# grows until the machine runs out of memory.

MAX_REPEAT = Limit(1000, "BENCHBOT_MAX_REPEAT", "repetitions", integer=True, meaning="batch --repeat")
"""``benchbot batch --repeat``: runs of every (robot, environment) in one batch."""

MAX_BATCH_EPISODES = Limit(100_000, "BENCHBOT_MAX_BATCH_EPISODES", "episodes", integer=True,
                           meaning="episodes in one batch")
"""Episodes in one batch's plan (robots × environments × repetitions, × the levels of a ``--sweep``); checked
before the plan is made (:func:`benchbot.batch.plan.plan_episodes`)."""

MAX_WORKERS = Limit(256, "BENCHBOT_MAX_WORKERS", "workers", integer=True, meaning="batch --workers")
"""``benchbot batch --workers``: episodes run at once (each a process with its own backend)."""

MAX_RETRIES = Limit(100, "BENCHBOT_MAX_RETRIES", "retries", integer=True, meaning="batch --retries")
"""``benchbot batch --retries``: times a failed episode is run again."""

MAX_SEED = Limit((1 << 32) - 1, None, "", integer=True, meaning="--seed")
"""``--seed`` (``batch``, ``run``, ``ros2 sim``, ``sim render``) lies in 0 to this (NumPy's 32-bit seeds)."""

MAX_GENERATED_HOMES = Limit(10_000, "BENCHBOT_MAX_GENERATED_HOMES", "homes", integer=True,
                            meaning="homes in a generated batch or pack")
"""Homes in one generated batch (``procedural_val_<count>``) or one ``benchbot worlds generate --count`` pack
(:mod:`benchbot.core.world_generators`)."""

MAX_HOME_INDEX = Limit(10**9, None, "", integer=True, meaning="a generated home's index")
"""A generated home's index (``procedural_val_<index>``, ``benchbot worlds generate --start``) lies in 0 to this."""

DEFAULT_ACTION_TIMEOUT_S = 120.0
"""Seconds after which an action answers 504 (the episode stays usable), unless ``run --action-timeout`` says
otherwise (:func:`benchbot.server.build_app`); a default, not a :class:`Limit`, kept here so that the command
line reads it without importing the server."""

MAX_RENDER_SAMPLES = Limit(4096, None, "samples", integer=True, meaning="sim render --spp and --shadow-samples")
"""``benchbot sim render --spp`` and ``--shadow-samples``: rays per pixel (the renderer packs them in float32)."""

# --- child processes (benchbot.solutions.process_group) ----------------------------------------------------------------

MAX_LOG_BYTES = Limit(16 << 20, "BENCHBOT_MAX_LOG_BYTES", "bytes", integer=True, zero_means="no cap",
                      meaning="bytes of a solution's log (0: no cap)")
"""Bytes of a child's output (a submission's stdout and stderr) kept in its log; the rest is counted and dropped,
with a last line saying so. 0: no cap."""

STOP_GRACE_S = Limit(5.0, "BENCHBOT_STOP_GRACE_S", "seconds", zero_means="no grace",
                     meaning="seconds between SIGTERM and SIGKILL of a solution's group")
"""Seconds a child's process group has between SIGTERM and SIGKILL when its episode ends. 0: no grace (SIGKILL
right after SIGTERM)."""

SANDBOX_TMP_BYTES = Limit(1 << 30, "BENCHBOT_SANDBOX_TMP_BYTES", "bytes", integer=True,
                          meaning="bytes of a sandboxed solution's private /tmp")
"""Bytes a sandboxed solution may keep in its private ``/tmp`` (a tmpfs, so in memory; :mod:`benchbot.solutions.sandbox`):
past it, writes there fail with "No space left on device"."""

SANDBOX_MEMORY_BYTES = Limit(8 << 30, "BENCHBOT_SANDBOX_MEMORY_BYTES", "bytes", integer=True,
                             meaning="bytes of data memory of each process of a sandboxed solution")
"""A sandboxed solution's memory: a memory cgroup over the whole sandbox where one can be made, and ``RLIMIT_DATA``
of each of its processes (its heap and every private writable mapping: what NumPy and malloc allocate). Not ``RLIMIT_AS``: that counts address space merely reserved (thread
stacks, glibc's 64 MiB malloc arenas per thread, CUDA's reservations), so a NumPy or PyTorch solution that uses
little memory would fail. Past it an allocation fails (Python: ``MemoryError``) and the episode ends
``resource_limit`` (:mod:`benchbot.solutions.sandbox_limits`)."""

SANDBOX_PROCESSES = Limit(512, "BENCHBOT_SANDBOX_PROCESSES", "tasks", integer=True,
                          meaning="processes and threads of a sandboxed solution")
"""Processes and threads a sandboxed solution may have at once (bubblewrap's and the relay's few included): a pids
cgroup's ``pids.max`` over the whole sandbox where one can be made, else ``RLIMIT_NPROC`` set inside the sandbox's
user namespace, where it counts that namespace's tasks only (but never binds root). Threads count (a BLAS library
starts one per core). Past it ``fork``/``clone`` fail (``EAGAIN``) and the episode ends ``resource_limit``."""

SANDBOX_FILE_BYTES = Limit(1 << 30, "BENCHBOT_SANDBOX_FILE_BYTES", "bytes", integer=True,
                           meaning="bytes of one file a sandboxed solution writes")
"""Bytes of any one file a sandboxed solution writes (its outputs folder, its ``/tmp``): ``RLIMIT_FSIZE``. Past it
the write fails (``EFBIG``; ``SIGXFSZ`` for programs that do not ignore it) and the episode ends
``resource_limit``."""

SANDBOX_OUTPUTS_BYTES = Limit(4 << 30, "BENCHBOT_SANDBOX_OUTPUTS_BYTES", "bytes", integer=True,
                              meaning="bytes a sandboxed solution keeps in its outputs folder, all files together")
"""Bytes a sandboxed solution may keep in its outputs folder, all its files together (the disk they take, links not
followed): the folder is measured every :data:`benchbot.solutions.process_group.STOP_WHEN_PERIOD_S` while the solution
runs, and a solution past it is stopped and its episode ends ``resource_limit``. A measurement, not a quota: a
solution writing fast can pass it by what it writes in that period (each file stays under
:data:`SANDBOX_FILE_BYTES`)."""

SANDBOX_CPU_S = Limit(36000, "BENCHBOT_SANDBOX_CPU_S", "seconds", integer=True,
                      meaning="CPU seconds of each process of a sandboxed solution")
"""CPU seconds (all its threads together) each process of a sandboxed solution may use: ``RLIMIT_CPU`` (``SIGXCPU``
at the limit, ``SIGKILL`` one second later). A backstop beside the episode's wall-clock timeout. Past it the
episode ends ``resource_limit``."""

RAY_EPISODE_BYTES = Limit(1 << 30, "BENCHBOT_RAY_EPISODE_BYTES", "bytes", integer=True,
                          meaning="bytes of the files an episode on a Ray node sends back")
"""Bytes of the files an episode run on a Ray node may send back to the batch (its results, log, outputs folder,
trajectory, recording: :func:`benchbot.batch.executors.run_ray`), which pass whole through the node's memory, Ray's
object store and the batch process's memory. Past it the episode ends as ``error`` and only its log comes back."""

# --- caches (benchbot_sim_taichi.scene_cache) -----------------------------------------------------------------------

SCENE_CACHE_BYTES = Limit(4 << 30, "BENCHBOT_SCENE_CACHE_BYTES", "bytes", integer=True, zero_means="no cache",
                          meaning="bytes of the simulator's scene cache in the cache directory (0: no cache)")
"""Bytes the simulator's cache of built scenes (scene arrays, BVH, shadow maps, baked light: tens to hundreds of MiB
an environment) may take in the cache directory (:func:`benchbot.packs.pack_layout.cache_dir`): past it, the entries
used longest ago are removed after each write. 0: scenes are neither read from nor written to the cache."""
