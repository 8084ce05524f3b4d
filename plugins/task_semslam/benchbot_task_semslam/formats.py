"""The object-map results formats of the semantic SLAM and scene change detection (SCD) tasks.

Three formats, re-built from QUT's ``formats_object_map`` add-on (BenchBot 2020, docs/original-benchbot.md, section 7):

* ``object_map`` (results of ``semantic_slam:*`` tasks)::

      {"objects": [{"label_probs": [float] * len(class_list),
                    "centroid": [x, y, z],      # metres, map frame
                    "extent": [dx, dy, dz]}],   # metres, FULL side lengths of an axis-aligned box
       "class_list": [str, ...]}

* ``object_map_with_states`` (results of ``scd:*`` tasks): as above plus a top-level ``state_list``
  (default ``["added", "removed", "unchanged"]``) and per object ``state_probs`` (one per ``state_list`` entry).
* ``object_map_ground_truth`` (ground-truth instances)::

      {"objects": [{"class": str, "ID_name": str, "centroid": [x, y, z], "extent": [dx, dy, dz],
                    "isgroup": bool}],
       "class_list": [str, ...], "synonyms": {alias: class}}

Each format's functions are referenced from ``formats/*.yaml`` as ``"benchbot_task_semslam.formats:<fn>"``.
Every ``validate_*`` raises :class:`benchbot.core.errors.ResultsError` at the *first* problem found; the message
names the JSON path inside the format instance (e.g. ``objects[3].extent: expected 3 numbers, got 2``).

Fixed bugs of the original validators: the ``objects`` type check was always true; the extent message said
"centroid"; a missing ``class_list`` raised ``KeyError``; ``state_probs`` length was never checked; numbers were not
checked for being finite (nor, here, for fitting a float: a 400-digit integer is refused by its JSON path, not an
``OverflowError``); extents could be negative; the ground-truth format had no validator.
"""

from __future__ import annotations

import math
import sys
from numbers import Real
from typing import Any, Optional

from benchbot.core.errors import ResultsError

DEFAULT_CLASS_LIST: tuple[str, ...] = (
    "bottle", "cup", "knife", "bowl", "wine glass", "fork", "spoon", "banana", "apple", "orange", "cake",
    "potted plant", "mouse", "keyboard", "laptop", "cell phone", "book", "clock", "chair", "table", "couch", "bed",
    "toilet", "tv", "microwave", "toaster", "refrigerator", "oven", "sink", "person", "background",
)  # fmt: skip
"""The 31 default class names of the BenchBot semantic SLAM challenge; ``background`` is last."""

DEFAULT_STATE_LIST: tuple[str, ...] = ("added", "removed", "unchanged")
"""The default SCD state names; the OMQ evaluator uses state ids added 0, removed 1, unchanged 2."""

__all__ = [
    "DEFAULT_CLASS_LIST",
    "DEFAULT_STATE_LIST",
    "create_object_map",
    "create_object_map_object",
    "validate_object_map",
    "create_object_map_with_states",
    "create_object_map_with_states_object",
    "validate_object_map_with_states",
    "create_object_map_ground_truth",
    "create_object_map_ground_truth_object",
    "validate_object_map_ground_truth",
]

_VALIDATE_HINT = "see the format's description (benchbot_task_semslam/formats/{name}.yaml)"


# --------------------------------------------------------------------------------------------------------------------
# create
# --------------------------------------------------------------------------------------------------------------------
def create_object_map(class_list: Optional[list[str]] = None) -> dict:
    """Return an empty ``object_map`` instance.

    Args:
        class_list: the class names the label probabilities refer to; default :data:`DEFAULT_CLASS_LIST`
            (31 names, ``background`` last).

    Returns:
        ``{"objects": [], "class_list": [str, ...]}`` (a fresh list, safe to mutate).
    """
    return {"objects": [], "class_list": list(DEFAULT_CLASS_LIST if class_list is None else class_list)}


def create_object_map_object(num_classes: Optional[int] = None) -> dict:
    """Return one zeroed ``object_map`` object.

    Args:
        num_classes: number of label probabilities; default ``len(DEFAULT_CLASS_LIST)`` (31).

    Returns:
        ``{"label_probs": [0.0] * num_classes, "centroid": [0.0, 0.0, 0.0], "extent": [0.0, 0.0, 0.0]}``;
        centroid and extent are in metres in the ``map`` frame, extent being the full side lengths of an
        axis-aligned box.
    """
    n = len(DEFAULT_CLASS_LIST) if num_classes is None else int(num_classes)
    return {"label_probs": [0.0] * n, "centroid": [0.0, 0.0, 0.0], "extent": [0.0, 0.0, 0.0]}


def create_object_map_with_states(
    class_list: Optional[list[str]] = None, state_list: Optional[list[str]] = None
) -> dict:
    """Return an empty ``object_map_with_states`` instance.

    Args:
        class_list: default :data:`DEFAULT_CLASS_LIST`.
        state_list: default :data:`DEFAULT_STATE_LIST` (``added``, ``removed``, ``unchanged``).

    Returns:
        ``{"objects": [], "class_list": [...], "state_list": [...]}``.
    """
    instance = create_object_map(class_list)
    instance["state_list"] = list(DEFAULT_STATE_LIST if state_list is None else state_list)
    return instance


def create_object_map_with_states_object(num_classes: Optional[int] = None, num_states: Optional[int] = None) -> dict:
    """Return one zeroed ``object_map_with_states`` object: :func:`create_object_map_object` plus
    ``"state_probs": [0.0] * num_states`` (default 3)."""
    obj = create_object_map_object(num_classes)
    obj["state_probs"] = [0.0] * (len(DEFAULT_STATE_LIST) if num_states is None else int(num_states))
    return obj


def create_object_map_ground_truth(
    class_list: Optional[list[str]] = None, synonyms: Optional[dict[str, str]] = None
) -> dict:
    """Return an empty ``object_map_ground_truth`` instance:
    ``{"objects": [], "class_list": [...], "synonyms": {alias: class}}`` (defaults: the 31 default classes, no
    synonyms)."""
    instance = create_object_map(class_list)
    instance["synonyms"] = dict(synonyms or {})
    return instance


def create_object_map_ground_truth_object(class_name: str = "background", id_name: str = "") -> dict:
    """Return one ground-truth object ``{"class", "ID_name", "centroid", "extent", "isgroup"}`` with a zero box
    (metres, map frame) and ``isgroup`` False. The keys are those of the shipped BEAR ground-truth files."""
    return {
        "class": class_name,
        "ID_name": id_name,
        "centroid": [0.0, 0.0, 0.0],
        "extent": [0.0, 0.0, 0.0],
        "isgroup": False,
    }


# --------------------------------------------------------------------------------------------------------------------
# validate
# --------------------------------------------------------------------------------------------------------------------
def _fail(path: str, what: str, fmt: str) -> None:
    raise ResultsError(f"{path}: {what}" if path else what, _VALIDATE_HINT.format(name=fmt))


def _describe(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _is_number(value: Any) -> bool:
    return isinstance(value, Real) and not isinstance(value, bool)


def _finite(value: Real) -> bool:
    """Whether the real number ``value`` is finite *as a float*: an integer beyond a float's range (a 400-digit
    JSON integer) is not (``math.isfinite`` would raise ``OverflowError`` on it)."""
    try:
        return math.isfinite(float(value))
    except OverflowError:
        return False


def _describe_number(value: Real) -> str:
    """``inf``, ``nan``, ``1e+300``; an integer too large for a float as ``an integer of 401 digits`` (never its
    digits: the message stays one short line)."""
    if isinstance(value, int) and abs(value) > sys.float_info.max:
        return f"an integer of {len(str(abs(value)))} digits (beyond a float's range, ±{sys.float_info.max:.2g})"
    return repr(value)


def _check_numbers(
    value: Any, path: str, fmt: str, length: int, what: str = "numbers", non_negative: bool = False
) -> None:
    """Check ``value`` is a list of ``length`` finite (optionally non-negative) real numbers, each within a
    float's range (``±1.8e308``: a JSON integer of hundreds of digits is refused, naming its JSON path)."""
    if not isinstance(value, (list, tuple)):
        _fail(path, f"expected a list of {length} {what}, got {type(value).__name__}", fmt)
    if len(value) != length:
        _fail(path, f"expected {length} {what}, got {len(value)}", fmt)
    for i, v in enumerate(value):
        if not _is_number(v):
            _fail(f"{path}[{i}]", f"expected a number, got {_describe(v)}", fmt)
        if not _finite(v):
            _fail(f"{path}[{i}]", f"expected a finite number, got {_describe_number(v)}", fmt)
        if non_negative and v < 0:
            _fail(f"{path}[{i}]", f"expected a number >= 0, got {v!r}", fmt)


def _check_name_list(instance: dict, key: str, fmt: str) -> list:
    if key not in instance:
        _fail(key, "missing (a non-empty list of strings)", fmt)
    names = instance[key]
    if not isinstance(names, list):
        _fail(key, f"expected a non-empty list of strings, got {type(names).__name__}", fmt)
    if not names:
        _fail(key, "expected a non-empty list of strings, got an empty list", fmt)
    for i, name in enumerate(names):
        if not isinstance(name, str):
            _fail(f"{key}[{i}]", f"expected a string, got {_describe(name)}", fmt)
    return names


def _check_objects(instance: Any, fmt: str) -> list:
    if not isinstance(instance, dict):
        _fail("", f"expected the results instance to be a JSON object (dict), got {type(instance).__name__}", fmt)
    if "objects" not in instance:
        _fail("objects", "missing (a list of objects)", fmt)
    objects = instance["objects"]
    if not isinstance(objects, list):
        _fail("objects", f"expected a list, got {type(objects).__name__}", fmt)
    for i, obj in enumerate(objects):
        if not isinstance(obj, dict):
            _fail(f"objects[{i}]", f"expected an object (dict), got {type(obj).__name__}", fmt)
    return objects


def _check_box(obj: dict, path: str, fmt: str) -> None:
    for key in ("centroid", "extent"):
        if key not in obj:
            _fail(f"{path}.{key}", "missing (a list of 3 numbers, metres)", fmt)
    _check_numbers(obj["centroid"], f"{path}.centroid", fmt, 3)
    _check_numbers(obj["extent"], f"{path}.extent", fmt, 3, non_negative=True)


def _check_probs(obj: dict, path: str, key: str, names_key: str, n: int, fmt: str) -> None:
    """``obj[key]``: ``n`` finite probabilities >= 0, one per entry of the instance's ``names_key``."""
    if key not in obj:
        _fail(f"{path}.{key}", f"missing (a list of {n} probabilities)", fmt)
    _check_numbers(obj[key], f"{path}.{key}", fmt, n, what=f"probabilities (one per {names_key} entry)",
                   non_negative=True)


def _validate_object_map(instance: Any, fmt: str, with_states: bool) -> None:
    objects = _check_objects(instance, fmt)
    class_list = _check_name_list(instance, "class_list", fmt)
    state_list = _check_name_list(instance, "state_list", fmt) if with_states else None
    for i, obj in enumerate(objects):
        path = f"objects[{i}]"
        _check_probs(obj, path, "label_probs", "class_list", len(class_list), fmt)
        _check_box(obj, path, fmt)
        if with_states:
            _check_probs(obj, path, "state_probs", "state_list", len(state_list), fmt)


def validate_object_map(results_instance: Any) -> None:
    """Validate an ``object_map`` instance (the ``results`` part of a submitted results file).

    Checks: the instance is a dict; ``objects`` is a list of dicts; ``class_list`` is a non-empty list of strings;
    every object's ``label_probs`` is a list of ``len(class_list)`` finite numbers >= 0; ``centroid`` and
    ``extent`` are lists of 3 finite numbers (metres, map frame), with every extent >= 0.

    Raises:
        benchbot.core.errors.ResultsError: at the first problem, e.g. ``objects[3].extent: expected 3 numbers,
            got 2``.
    """
    _validate_object_map(results_instance, "object_map", with_states=False)


def validate_object_map_with_states(results_instance: Any) -> None:
    """Validate an ``object_map_with_states`` instance: everything :func:`validate_object_map` checks, plus
    ``state_list`` is a non-empty list of strings and every object's ``state_probs`` is a list of
    ``len(state_list)`` finite numbers >= 0.

    Raises:
        benchbot.core.errors.ResultsError: at the first problem, naming its JSON path.
    """
    _validate_object_map(results_instance, "object_map_with_states", with_states=True)


def validate_object_map_ground_truth(results_instance: Any) -> None:
    """Validate an ``object_map_ground_truth`` instance (the ``ground_truth`` part of a ground-truth file).

    Checks: ``objects`` is a list of dicts; ``class_list`` a non-empty list of strings; ``synonyms`` (optional) a
    dict of string to string; every object has ``class`` (a string that is in ``class_list`` or a key of
    ``synonyms``, case-insensitive), ``ID_name`` (optional, a string), ``centroid``/``extent`` (3 finite numbers,
    metres, map frame, extents >= 0) and ``isgroup`` (optional, a bool).

    Raises:
        benchbot.core.errors.ResultsError: at the first problem, naming its JSON path.
    """
    fmt = "object_map_ground_truth"
    objects = _check_objects(results_instance, fmt)
    class_list = _check_name_list(results_instance, "class_list", fmt)
    synonyms = results_instance.get("synonyms", {})
    if not isinstance(synonyms, dict):
        _fail("synonyms", f"expected an object mapping alias to class name, got {type(synonyms).__name__}", fmt)
    for alias, target in synonyms.items():
        if not isinstance(alias, str) or not isinstance(target, str):
            _fail(f"synonyms[{alias!r}]", f"expected a string mapped to a string, got {_describe(target)}", fmt)
    known = {c.lower() for c in class_list} | {a.lower() for a in synonyms}
    for i, obj in enumerate(objects):
        path = f"objects[{i}]"
        if "class" not in obj:
            _fail(f"{path}.class", "missing (a class name)", fmt)
        if not isinstance(obj["class"], str):
            _fail(f"{path}.class", f"expected a string, got {_describe(obj['class'])}", fmt)
        if obj["class"].lower() not in known:
            _fail(f"{path}.class", f"{obj['class']!r} is neither in class_list nor a synonym", fmt)
        if "ID_name" in obj and not isinstance(obj["ID_name"], str):
            _fail(f"{path}.ID_name", f"expected a string, got {_describe(obj['ID_name'])}", fmt)
        if "isgroup" in obj and not isinstance(obj["isgroup"], bool):
            _fail(f"{path}.isgroup", f"expected true or false, got {_describe(obj['isgroup'])}", fmt)
        _check_box(obj, path, fmt)
