"""The backend's limits on what one request may ask for: one home for every bound the server and the episode
enforce, each with its default, its environment variable and the error a client sees.

======================================  ===========  ======================================  ======================
limit                                   default      environment variable                    a client over it gets
======================================  ===========  ======================================  ======================
:data:`MAX_REQUEST_BYTES`               1 MiB        ``BENCHBOT_MAX_REQUEST_BYTES``          413, before the body
                                                                                             is read
:data:`MAX_OBSERVATION_NAMES`           64           ``BENCHBOT_MAX_OBSERVATION_NAMES``      400
:data:`MAX_RESULTS_ARG_NUMBER`          100000       ``BENCHBOT_MAX_RESULTS_ARG_NUMBER``     400
:data:`MAX_RESULTS_REPLY_BYTES`         8 MiB        ``BENCHBOT_MAX_RESULTS_REPLY_BYTES``    400
:data:`RESULTS_FUNCTION_TIMEOUT_S`      10 s         ``BENCHBOT_RESULTS_FUNCTION_TIMEOUT_S`` 504
:data:`EPISODE_LEASE_S`                 60 s         ``BENCHBOT_EPISODE_LEASE_S``            409 (to other
                                                                                             clients)
:data:`MAX_MOVE_DISTANCE_M`             100 m        ``BENCHBOT_MAX_MOVE_DISTANCE_M``        400
:data:`MAX_MOVE_ANGLE_DEG`              360°         ``BENCHBOT_MAX_MOVE_ANGLE_DEG``         400
:data:`MAX_CAMERA_SIDE`                 8192 px      (none: a flag's bound)                  usage error (exit 2)
======================================  ===========  ======================================  ======================

Values are read from the environment when used (:meth:`Limit.value`); a variable that is not a positive number is
a one-line :class:`~benchbot.core.errors.UsageError` naming it.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from benchbot.core.errors import UsageError


@dataclass(frozen=True)
class Limit:
    """A positive bound with a default and an environment variable that overrides it.

    Attributes:
        default: the bound when the variable is unset or empty.
        env: the environment variable (``None``: not overridable).
        integer: the bound is a whole number (bytes, counts).
    """

    default: float
    env: str | None = None
    integer: bool = False

    def value(self) -> float:
        """The bound now: ``$env`` when set and non-empty, else :attr:`default`.

        Raises:
            UsageError: ``$env`` is not a positive (whole, for :attr:`integer` limits) finite number.
        """
        raw = os.environ.get(self.env, "").strip() if self.env else ""
        if not raw:
            return self.default
        try:
            number = int(raw) if self.integer else float(raw)
        except ValueError:
            number = -1
        if not (math.isfinite(number) and number > 0):
            kind = "positive whole number" if self.integer else "positive number"
            raise UsageError(f"${self.env}={raw!r} is not a {kind}", f"unset it for the default ({self.default:g})")
        return number

    def __str__(self) -> str:
        where = f" (${self.env})" if self.env else ""
        return f"{self.value():g}{where}"


#: Request bodies larger than this are answered 413 without being read (``Content-Length`` is checked first;
#: a chunked body is cut off as soon as it passes the bound).
MAX_REQUEST_BYTES = Limit(1024 * 1024, "BENCHBOT_MAX_REQUEST_BYTES", integer=True)
#: Observation names one native step may ask for (a task observes fewer than ten).
MAX_OBSERVATION_NAMES = Limit(64, "BENCHBOT_MAX_OBSERVATION_NAMES", integer=True)
#: Every number in a results function's ``args``/``kwargs`` — and every string that reads as a number — must lie
#: within ± this. The server cannot tell which argument is a count (``create_object(num_classes)``), so one bound
#: covers counts and coordinates alike (map coordinates are metres; label probabilities lie in [0, 1]).
MAX_RESULTS_ARG_NUMBER = Limit(100_000, "BENCHBOT_MAX_RESULTS_ARG_NUMBER")
#: The JSON reply of one results-function call.
MAX_RESULTS_REPLY_BYTES = Limit(8 * 1024 * 1024, "BENCHBOT_MAX_RESULTS_REPLY_BYTES", integer=True)
#: A results function still running after this answers 504; results functions run one at a time on their own
#: thread, never on the server's event loop or the backend thread.
RESULTS_FUNCTION_TIMEOUT_S = Limit(10.0, "BENCHBOT_RESULTS_FUNCTION_TIMEOUT_S")
#: An episode belongs to the client that started it until that client releases it (``/robot/release``) or sends
#: no request for this long; until then other clients get 409 (docs/protocol.md, "One client at a time").
EPISODE_LEASE_S = Limit(60.0, "BENCHBOT_EPISODE_LEASE_S")
#: ``move_distance``'s ``distance`` must lie within ± this (metres).
MAX_MOVE_DISTANCE_M = Limit(100.0, "BENCHBOT_MAX_MOVE_DISTANCE_M")
#: ``move_angle``'s ``angle`` must lie within ± this (degrees).
MAX_MOVE_ANGLE_DEG = Limit(360.0, "BENCHBOT_MAX_MOVE_ANGLE_DEG")
#: ``--camera-size WxH``: each side at most this many pixels.
MAX_CAMERA_SIDE = Limit(8192, integer=True)
