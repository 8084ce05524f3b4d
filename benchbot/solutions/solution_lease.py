"""A supervisor's side of "one client at a time" (docs/protocol.md): the client id it gives the solution it runs,
the check that the episode is free before the solution starts, and the release once the solution has ended.

``benchbot submit`` runs a solution against a ``benchbot run`` backend in another process. It names the solution's
client itself (:func:`new_client_id`, given to the solution as ``BENCHBOT_CLIENT_ID``, which :mod:`benchbot.api`
sends as ``X-BenchBot-Client``), so that once the solution's process group has ended, however it ended (it
returned, crashed, timed out, was killed with SIGKILL mid-episode), :func:`release_solution` ends that client's hold
on the episode: the next submission starts at once instead of being refused until the backend's idle lease runs
out. An original ``benchbot_api`` client sends no id (it is the anonymous client of its address) and never releases
the episode: the release names the anonymous client too.
"""

from __future__ import annotations

import contextlib
import http.client
import json
import os
import secrets
from typing import Any, Iterator

from benchbot.core import settings
from benchbot.protocol import wire
from benchbot.core.errors import BackendError

#: The environment variable that names a solution's client (read by :mod:`benchbot.api`).
CLIENT_ID_VARIABLE = "BENCHBOT_CLIENT_ID"
#: Seconds each of these requests may take (the backend answers them on its event loop, in milliseconds).
TIMEOUT_S = 5.0


def new_client_id() -> str:
    """A fresh client id for one run of a solution: ``solution-`` and 32 random hex digits."""
    return "solution-" + secrets.token_hex(16)


def _request(address: str, route: str, *, client_id: str | None = None, body: dict | None = None) -> tuple[int, Any]:
    """``POST route`` with a JSON ``body`` (as ``client_id`` when given, with ``$BENCHBOT_TOKEN`` when set), on a
    connection of its own (:func:`~benchbot.protocol.wire.request_once`, which the client uses too): ``(status,
    parsed JSON)``.

    Raises:
        OSError, http.client.HTTPException, ValueError: no answer, or one that is not JSON.
    """
    headers = {"content-type": "application/json"}
    if client_id:
        headers[wire.CLIENT_HEADER] = client_id
    token = settings.get("BENCHBOT_TOKEN")
    if token:
        headers[wire.TOKEN_HEADER] = token
    status, data = wire.request_once(address, "POST", route, body=json.dumps(body or {}).encode(), headers=headers,
                                     connect_timeout_s=TIMEOUT_S, read_timeout_s=TIMEOUT_S)
    return status, json.loads(data) if data else None


def check_episode_free(address: str, client_id: str) -> None:
    """Make sure no other client holds the backend's episode before a solution is started against it
    (``robot/is_free`` as ``client_id``: it claims and changes nothing).

    Raises:
        BackendError: another client holds the episode (one line: the backend's reason, and the fix).
    """
    try:
        status, answer = _request(address, "robot/is_free", client_id=client_id)
        answer = answer if status == 200 else {}
    except (http.client.HTTPException, OSError, ValueError):
        return  # the backend was just checked: the solution meets whatever failed, in one line of its own
    if isinstance(answer, dict) and answer.get("is_free") is False:
        raise BackendError(f"the backend at {address} is in use: {answer.get('error')}",
                           str(answer.get("hint") or "wait for the other client to end, or start another backend"))


def release_solution(address: str, client_id: str) -> bool | None:
    """End the hold of a solution that has ended: ``robot/release`` with ``{"client": client_id, "anonymous":
    true}`` (the solution's own id, and an original client's anonymous one). The backend takes it from its own host
    (loopback) or from a caller with its token only; ``client_id`` is refused by the backend from then on.

    Returns:
        Whether the solution's client held the episode; None when the backend did not answer (it is gone: nothing
        to release) or refused.
    """
    try:
        status, answer = _request(address, "robot/release", body={"client": client_id, "anonymous": True})
        return bool(answer["release_success"]) if status == 200 else None
    except (http.client.HTTPException, OSError, ValueError, KeyError, TypeError):
        return None


@contextlib.contextmanager
def supervised_solution(address: str) -> Iterator[str]:
    """Around running one solution against the backend at ``address``: checks that the episode is free
    (:func:`check_episode_free`), sets ``BENCHBOT_CLIENT_ID`` to a fresh id in this process's environment for the
    duration (the solution's processes inherit it: native, sandboxed, or passed into a container), and, on leaving,
    however the block ends (the solution returned, crashed, timed out, was killed; Ctrl-C), releases its hold
    (:func:`release_solution`). Yields the id.

    Raises:
        BackendError: another client holds the episode (before anything runs).
    """
    client_id = new_client_id()
    check_episode_free(address, client_id)
    previous = os.environ.get(CLIENT_ID_VARIABLE)
    os.environ[CLIENT_ID_VARIABLE] = client_id
    try:
        yield client_id
    finally:
        if previous is None:
            os.environ.pop(CLIENT_ID_VARIABLE, None)
        else:
            os.environ[CLIENT_ID_VARIABLE] = previous
        release_solution(address, client_id)
