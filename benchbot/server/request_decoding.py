"""Decoding what a client sends, within limits: JSON bodies, MessagePack step bodies, results-function arguments.

Request bodies are only ever parsed as JSON or MessagePack: nothing a client sends is unpickled. Every bound a
request can reach is in :mod:`benchbot.core.limits` (the body's size is bounded before it is read, by
:class:`~benchbot.server.middleware.BodyLimit`); bodies of at least :data:`PARSE_OFF_LOOP_BYTES` are parsed on
a worker thread, never on the event loop (:func:`~benchbot.server.routes.build_app`).
"""

from __future__ import annotations

import json
import math
from typing import Any

from benchbot.core import limits
from benchbot.protocol import wire
from benchbot.core.errors import BenchbotError
from benchbot.server.http_errors import BadRequestError

#: Request bodies at least this large are parsed on a worker thread, not on the event loop.
PARSE_OFF_LOOP_BYTES = 64 * 1024


def _reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not allowed")


def parse_json_body(raw: bytes) -> dict:
    """The JSON object of a request body (``{}`` when empty).

    Raises:
        BadRequestError: not JSON (NaN/Infinity included), or not an object.
    """
    if not raw.strip():
        return {}
    try:
        body = json.loads(raw, parse_constant=_reject_constant)
    except (ValueError, UnicodeDecodeError, RecursionError):
        raise BadRequestError("request body is not valid JSON", "send a JSON object or nothing") from None
    if not isinstance(body, dict):
        raise BadRequestError(f"request body must be a JSON object, got {type(body).__name__}", "e.g. {}")
    return body


def parse_step_body(raw: bytes) -> dict:
    """The MessagePack map of a ``/native/step`` body (:func:`benchbot.protocol.wire.unpack`; ``{}`` when empty).

    Raises:
        BadRequestError: not a valid payload, or not a map.
    """
    try:
        body = wire.unpack(raw) if raw else {}
    except BenchbotError as exc:
        raise BadRequestError(exc.message, exc.hint) from None
    if not isinstance(body, dict):
        raise BadRequestError("step request must be a map", "send {action, args}")
    return body


def _as_number(value: int | float | str) -> float | None:
    """``value`` as a float (``inf`` for integers too large for one); a string only when it reads as a number
    (a long string of digits counts as ``inf``); None otherwise."""
    if isinstance(value, str):
        text = value.strip()
        if len(text) > 400:
            return math.inf if text.lstrip("+-").replace("_", "").isdigit() else None
        try:
            return float(text)
        except ValueError:
            return None
    try:
        return float(value)
    except OverflowError:
        return math.inf


def check_results_arguments(args: Any, kwargs: Any) -> None:
    """Refuse results-function arguments that ask for more than :data:`~benchbot.core.limits.MAX_RESULTS_ARG_NUMBER`:
    every number, and every string that reads as one, must lie within its ± bound (the server cannot tell which
    argument a function uses as a count). Walks the arguments without recursion (any nesting depth).

    Raises:
        BadRequestError: naming the first value past the bound and the variable that raises it.
        UsageError: the bound's environment variable is not a positive number.
    """
    bound = limits.MAX_RESULTS_ARG_NUMBER.value()
    stack: list[Any] = [args, kwargs]
    while stack:
        node = stack.pop()
        if isinstance(node, dict):
            stack.extend(node.keys())
            stack.extend(node.values())
        elif isinstance(node, list):
            stack.extend(node)
        elif isinstance(node, (int, float, str)) and not isinstance(node, bool):
            number = _as_number(node)
            if number is not None and abs(number) > bound:
                shown = repr(node) if len(repr(node)) <= 40 else repr(node)[:37] + "..."
                raise BadRequestError(
                    f"results function argument {shown} is past the limit of ±{bound:g}",
                    f"arguments (counts included) must lie within ±{bound:g}; "
                    f"${limits.MAX_RESULTS_ARG_NUMBER.env} on the backend raises it",
                )
