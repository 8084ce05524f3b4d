"""The server's errors and their HTTP statuses: every error is JSON ``{"error": message, "hint": hint}``.

400: a bad request, or an argument past its limit; 401: a missing or wrong token; 403: a supervisor's request
(releasing another client's episode) from a caller that is neither on loopback nor holding the token; 404: an
unknown route, key,
connection or results function; 405: a method the route does not take; 409: an action refused, or the episode
belongs to another client; 413: a body past :data:`~benchbot.core.limits.MAX_REQUEST_BYTES`; 500: a backend failure
(its message says which; paths of ground-truth files are blanked out, :mod:`benchbot.server.redaction`);
503: the robot stopped on a fault it detected (:class:`~benchbot.core.errors.RobotFaultError`: a sensor topic silent
past its limit, TF lost; the message names the topic and the setting); 504:
an action or results function that ran past its timeout (the motion still completes on the backend thread and the
episode stays usable).
"""

from __future__ import annotations

from starlette.responses import JSONResponse

from benchbot.core.episode import ActionArgumentError
from benchbot.core.errors import ActionError, BackendError, BenchbotError, RobotFaultError
from benchbot.server.redaction import redact


class NotFoundError(BenchbotError):
    """An unknown route, config key, robot command, connection or results function (HTTP 404)."""


class BadRequestError(BenchbotError):
    """A malformed request body or argument (HTTP 400)."""


class ActionTimeoutError(BackendError):
    """An action ran past the server's action timeout (HTTP 504)."""


class UnauthorizedError(BenchbotError):
    """A request without the server's token (HTTP 401)."""


class ForbiddenError(BenchbotError):
    """A request only the backend's host (loopback) or a token holder may make (HTTP 403)."""


class EpisodeInUseError(BenchbotError):
    """The episode belongs to another client (HTTP 409; :class:`~benchbot.server.ownership.EpisodeOwnership`)."""


class PayloadTooLargeError(BenchbotError):
    """A request body past :data:`~benchbot.core.limits.MAX_REQUEST_BYTES` (HTTP 413)."""


#: ``(error classes, HTTP status)``, most specific first: the first row whose classes match an error gives its status
#: (``ActionArgumentError`` is an ``ActionError``; ``ActionTimeoutError`` and ``RobotFaultError`` are
#: ``BackendError``; all are ``BenchbotError``).
STATUS_BY_ERROR: tuple[tuple[tuple[type, ...], int], ...] = (
    ((NotFoundError,), 404),
    ((UnauthorizedError,), 401),
    ((ForbiddenError,), 403),
    ((PayloadTooLargeError,), 413),
    ((ActionArgumentError,), 400),
    ((ActionError, EpisodeInUseError), 409),
    ((ActionTimeoutError,), 504),
    ((RobotFaultError,), 503),
    ((BackendError,), 500),
    ((BenchbotError,), 400),
)


def status_of(exc: BaseException) -> int:
    """The HTTP status of an error raised by :class:`~benchbot.server.operations.BackendApi` (an ``int``, from
    :data:`STATUS_BY_ERROR`; 500 for anything that is not a :class:`~benchbot.core.errors.BenchbotError`; never
    raises)."""
    return next((status for classes, status in STATUS_BY_ERROR if isinstance(exc, classes)), 500)


def error_response(status: int, exc: BaseException | str, hint: str = "",
                   hidden: set[str] | None = None) -> JSONResponse:
    """The JSON error reply ``{"error": message, "hint": hint}`` with HTTP ``status``.

    Args:
        status: the HTTP status code.
        exc: the error (a :class:`~benchbot.core.errors.BenchbotError` gives its own message and hint), or the
            message itself.
        hint: the hint when ``exc`` is not a :class:`~benchbot.core.errors.BenchbotError`.
        hidden: strings blanked out of the message and hint (:func:`~benchbot.server.redaction.redact`).
    """
    message = exc.message if isinstance(exc, BenchbotError) else str(exc)
    hint = exc.hint if isinstance(exc, BenchbotError) else hint
    if hidden:
        message, hint = redact(message, hidden), redact(hint, hidden)
    return JSONResponse({"error": message, "hint": hint}, status_code=status)
