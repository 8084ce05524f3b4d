"""The backend server: an :class:`~benchbot.core.episode.Episode` behind HTTP (127.0.0.1 by default).

Every episode call runs on one dedicated worker thread (Taichi and other simulators need a single thread); request
bodies are only ever parsed as JSON or MessagePack (nothing a client sends is unpickled); every bound a request can
reach is in :mod:`benchbot.core.limits`; the episode belongs to one client at a time. Its modules:

* :mod:`~benchbot.server.service`: :class:`BackendService`, the episode on the one backend thread;
* :mod:`~benchbot.server.operations`: :class:`BackendApi`, the operations that the routes and the in-process
  client (:mod:`benchbot.api`) share;
* :mod:`~benchbot.server.routes`: :func:`build_app`, the Starlette app and its routes (the table of routes);
* :mod:`~benchbot.server.request_decoding`: request bodies and results-function arguments, within limits;
* :mod:`~benchbot.server.ownership`: :class:`EpisodeOwnership`, one client at a time;
* :mod:`~benchbot.server.middleware`: body limit, token, merged slashes;
* :mod:`~benchbot.server.http_errors`: the errors and their HTTP statuses (:func:`status_of`);
* :mod:`~benchbot.server.redaction`: ground-truth paths blanked out of what is served;
* :mod:`~benchbot.server.server_thread`: :class:`ServerThread`, uvicorn on a background thread.

The names below are importable from here (``from benchbot.server import ServerThread, build_app``).
"""

from benchbot.server.http_errors import (
    ActionTimeoutError, BadRequestError, EpisodeInUseError, ForbiddenError, NotFoundError, PayloadTooLargeError,
    UnauthorizedError, status_of,
)
from benchbot.server.middleware import TOKEN_HEADER, BodyLimit, MergeSlashes, TokenGuard
from benchbot.server.operations import RGB_CALLBACK, ROBOT_GREETING, BackendApi
from benchbot.server.ownership import (
    CLIENT_HEADER, CLIENT_ID_PATTERN, READ_ONLY_COMMANDS, EpisodeOwnership, client_identity,
)
from benchbot.server.redaction import HIDDEN, ground_truth_strings, redact
from benchbot.server.request_decoding import PARSE_OFF_LOOP_BYTES, check_results_arguments, parse_json_body
from benchbot.server.routes import (
    DEFAULT_ACTION_TIMEOUT_S, MSGPACK, SUPERVISOR_GREETING, build_app, encode_jsonpickle,
)
from benchbot.server.server_thread import ServerThread
from benchbot.server.service import BackendService, backend_worker

__all__ = [
    "ActionTimeoutError", "BackendApi", "BackendService", "BadRequestError", "BodyLimit", "CLIENT_HEADER",
    "CLIENT_ID_PATTERN", "DEFAULT_ACTION_TIMEOUT_S", "EpisodeInUseError", "EpisodeOwnership", "ForbiddenError",
    "HIDDEN", "MSGPACK", "MergeSlashes", "NotFoundError", "PARSE_OFF_LOOP_BYTES", "PayloadTooLargeError",
    "READ_ONLY_COMMANDS", "RGB_CALLBACK", "ROBOT_GREETING", "SUPERVISOR_GREETING", "ServerThread", "TOKEN_HEADER", "TokenGuard",
    "UnauthorizedError", "backend_worker", "build_app", "check_results_arguments", "client_identity",
    "encode_jsonpickle", "ground_truth_strings", "parse_json_body", "redact", "status_of",
]
