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

import importlib

#: Where each name below is defined. They are imported on first use (PEP 562), so that importing one light module of
#: this package (``benchbot.server.redaction``, which the sandbox uses to hide ground truth) or a module that names
#: these only for typing loads no web server: uvicorn and Starlette took 0.04 s of every ``benchbot batch`` on the
#: 2-core CPU, whose episodes the simulator service serves.
_DEFINED_IN = {
    **dict.fromkeys(("ActionTimeoutError", "BadRequestError", "EpisodeInUseError", "ForbiddenError", "NotFoundError",
                     "PayloadTooLargeError", "UnauthorizedError", "status_of"), "http_errors"),
    **dict.fromkeys(("TOKEN_HEADER", "BodyLimit", "MergeSlashes", "TokenGuard"), "middleware"),
    **dict.fromkeys(("RGB_CALLBACK", "ROBOT_GREETING", "BackendApi"), "operations"),
    **dict.fromkeys(("CLIENT_HEADER", "CLIENT_ID_PATTERN", "READ_ONLY_COMMANDS", "EpisodeOwnership",
                     "client_identity"), "ownership"),
    **dict.fromkeys(("HIDDEN", "ground_truth_strings", "redact"), "redaction"),
    **dict.fromkeys(("PARSE_OFF_LOOP_BYTES", "check_results_arguments", "parse_json_body"), "request_decoding"),
    **dict.fromkeys(("DEFAULT_ACTION_TIMEOUT_S", "MSGPACK", "SUPERVISOR_GREETING", "build_app", "encode_jsonpickle"),
                    "routes"),
    "ServerThread": "server_thread",
    **dict.fromkeys(("BackendService", "backend_worker"), "service"),
}


def __getattr__(name: str):
    """``benchbot.server.<name>`` for the names of :data:`__all__`, imported from their module on first use.

    Raises:
        AttributeError: no such name."""
    module = _DEFINED_IN.get(name)
    if module is None:
        raise AttributeError(f"module 'benchbot.server' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"benchbot.server.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_DEFINED_IN})


__all__ = [
    "ActionTimeoutError", "BackendApi", "BackendService", "BadRequestError", "BodyLimit", "CLIENT_HEADER",
    "CLIENT_ID_PATTERN", "DEFAULT_ACTION_TIMEOUT_S", "EpisodeInUseError", "EpisodeOwnership", "ForbiddenError",
    "HIDDEN", "MSGPACK", "MergeSlashes", "NotFoundError", "PARSE_OFF_LOOP_BYTES", "PayloadTooLargeError",
    "READ_ONLY_COMMANDS", "RGB_CALLBACK", "ROBOT_GREETING", "SUPERVISOR_GREETING", "ServerThread", "TOKEN_HEADER", "TokenGuard",
    "UnauthorizedError", "backend_worker", "build_app", "check_results_arguments", "client_identity",
    "encode_jsonpickle", "ground_truth_strings", "parse_json_body", "redact", "status_of",
]
