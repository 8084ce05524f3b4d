"""When two specs of the same kind and name mean the same thing ("identical in meaning").

Two sources may offer a spec of the same name — a content pack copied from an original add-on and a first-party
plugin, say. When both say the same thing the second is not a clash: the registry keeps one and notes that the
other is already provided (``benchbot install`` reports it). Two specs are identical in meaning when their
*canonical forms* (:func:`canonical`) are equal:

* the parsed content is compared, never the text: key order, quoting, comments, YAML flow or block style and
  ``1`` against ``1.0`` make no difference (a boolean is never equal to a number);
* fields nothing reads are left out (:data:`INFORMATIONAL`): ``description`` of every kind, a task's ``type``
  (neither the original nor BenchBot checks it), an environment's ``robots`` list (informational in both), and
  ``_file_path`` at any depth (where the file was loaded from);
* a field left out equals its schema's ``default`` (a task's ``scene_count: 1`` and ``localisation:
  ground_truth``, a robot's ``global_frame: map``, ...);
* lists used only as sets compare as sets (:data:`UNORDERED`: a task's ``actions`` and ``observations``, an
  evaluator's ``valid_*_formats``, a robot's ``actions``, ``observations`` and ``environment_types``); every
  other list keeps its order (a batch's ``environments`` number its results files);
* an environment's ``variant`` compares as text (the original matched ``name:variant`` as strings); a ground
  truth's ``environment`` and ``format`` are full copies of an environment and a format file and compare by
  those kinds' rules.

Everything else counts: a different ``type``, ``connections``, ``map_path`` or ``functions`` is a different spec
(the functions of a pack's format are its own code, never "the same" as a plugin's).
"""

from __future__ import annotations

import json
from typing import Any

INFORMATIONAL: dict[str, frozenset[str]] = {
    "tasks": frozenset({"description", "type"}),
    "robots": frozenset({"description"}),
    "environments": frozenset({"description", "robots"}),
    "formats": frozenset({"description"}),
    "evaluators": frozenset({"description"}),
    "examples": frozenset({"description"}),
    "batches": frozenset({"description"}),
    "ground_truths": frozenset(),
}
"""Top-level fields of each kind that nothing reads (left out of the comparison); ``_file_path`` is left out at
every depth."""

UNORDERED: dict[str, frozenset[str]] = {
    "tasks": frozenset({"actions", "observations"}),
    "robots": frozenset({"actions", "observations", "environment_types"}),
    "evaluators": frozenset({"valid_result_formats", "valid_ground_truth_formats"}),
}
"""Top-level list fields of each kind whose order nothing uses (compared as sets)."""

_MISSING = ("missing",)
_NESTED_KINDS = {"ground_truths": {"environment": "environments", "format": "formats"}}
_SCHEMAS = {"tasks": "task", "robots": "robot", "environments": "environment", "formats": "format",
            "evaluators": "evaluator", "examples": "example", "batches": "batch", "ground_truths": "ground_truth"}


def _defaults(kind: str) -> dict[str, Any]:
    """``{field: default}`` of the top-level properties of the kind's schema that declare one."""
    from benchbot.core.specs import validator

    schema = validator(_SCHEMAS[kind]).schema
    return {key: prop["default"] for key, prop in (schema.get("properties") or {}).items()
            if isinstance(prop, dict) and "default" in prop}


def _value(value: Any) -> Any:
    """The canonical form of any parsed value: numbers as floats, booleans tagged apart from numbers,
    ``_file_path`` dropped from every mapping."""
    if isinstance(value, bool):
        return ("bool", value)
    if isinstance(value, (int, float)):
        return float(value)
    if isinstance(value, dict):
        return {str(k): _value(v) for k, v in value.items() if k != "_file_path"}
    if isinstance(value, (list, tuple)):
        return [_value(v) for v in value]
    return value


def _sort_key(value: Any) -> str:
    return json.dumps(value, sort_keys=True, default=repr)


def canonical(kind: str, spec: dict) -> dict:
    """The canonical form of a spec of ``kind`` (a registry kind: ``tasks``, ``robots``, ...): what is compared
    to decide whether two specs are identical in meaning (see the module's docstring)."""
    skip = INFORMATIONAL.get(kind, frozenset()) | {"_file_path"}
    out = {k: v for k, v in spec.items() if k not in skip}
    if kind in _SCHEMAS:
        for key, default in _defaults(kind).items():
            out.setdefault(key, default)
    if kind == "environments" and "variant" in out:
        out["variant"] = str(out["variant"])
    nested = _NESTED_KINDS.get(kind, {})
    result = {}
    for key, value in out.items():
        if key in nested and isinstance(value, dict):
            result[key] = canonical(nested[key], value)
        elif key in UNORDERED.get(kind, ()) and isinstance(value, list):
            result[key] = sorted({_sort_key(v): _value(v) for v in value}.values(), key=_sort_key)
        else:
            result[key] = _value(value)
    return result


def differences(kind: str, a: dict, b: dict) -> list[str]:
    """The top-level fields in which two specs of ``kind`` differ in meaning (sorted; empty when identical)."""
    ca, cb = canonical(kind, a), canonical(kind, b)
    return sorted(key for key in set(ca) | set(cb) if ca.get(key, _MISSING) != cb.get(key, _MISSING))


def same_meaning(kind: str, a: dict, b: dict) -> bool:
    """Whether two specs of ``kind`` are identical in meaning (see the module's docstring)."""
    return canonical(kind, a) == canonical(kind, b)

