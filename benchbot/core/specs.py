"""Spec files and their schemas: the kinds of content (:data:`KIND_SCHEMAS`), loading a spec file, validating it
against ``schemas/`` (JSON Schema 2020-12) and the checks a schema cannot express, a registered spec
(:class:`Entry`) and its index name. The registry (:mod:`benchbot.core.registry`) and content packs
(:mod:`benchbot.packs.content_packs`) both build on this module, which imports neither.
"""

from __future__ import annotations

import functools
import hashlib
import json
import marshal
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

from benchbot.core.errors import SpecError
from benchbot.core.limits import MAX_SPEC_BYTES
from benchbot.core.names import close_names
from benchbot.core.safe_load import load_data_file

if TYPE_CHECKING:
    import jsonschema

KIND_SCHEMAS = {
    "tasks": "task",
    "robots": "robot",
    "environments": "environment",
    "formats": "format",
    "evaluators": "evaluator",
    "examples": "example",
    "batches": "batch",
    "ground_truths": "ground_truth",
}


def schema_dir() -> Path:
    """The folder of the JSON Schemas: inside the installed wheel, or the repository's ``schemas/``."""
    packaged = resources.files("benchbot") / "schemas"
    if packaged.is_dir():
        return Path(str(packaged))
    return Path(__file__).resolve().parents[2] / "schemas"


@functools.lru_cache(maxsize=None)
def validator(schema_name: "str | Path") -> "jsonschema.Draft202012Validator":
    """The Draft 2020-12 validator of ``schemas/<schema_name>.schema.json``, or, when ``schema_name`` is a
    :class:`~pathlib.Path`, of that schema file (a plugin's schema of the fields its robot backend reads, shipped in
    the plugin's package: ``benchbot_<plugin>/schemas/``).

    Raises:
        OSError: the schema file cannot be read. jsonschema.SchemaError: it is not a valid Draft 2020-12 schema.
    """
    # imported here: a command whose specs are all known valid (ValidStore) needs no validator, and importing
    # jsonschema (with referencing, attrs, rpds) took 30-40 ms of every command's start on the 2-core CPU
    import jsonschema

    path = schema_name if isinstance(schema_name, Path) else schema_dir() / f"{schema_name}.schema.json"
    schema = json.loads(path.read_text(encoding="utf-8"))
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def json_path(path: "list[Any] | Any") -> str:
    """``$.a.b[3].c`` from a jsonschema error path."""
    out = "$"
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else f".{part}"
    return out


def first_error(instance: Any, schema_name: "str | Path") -> "tuple[str, str] | None":
    """The first error (by path) of ``instance`` against a schema (``schema_name`` as for :func:`validator`), as
    ``(<$.json.path>, <message>)``, or ``None`` when it is valid. The message is jsonschema's, one line; where an
    ``anyOf``/``oneOf`` fails and its schema has a ``description``, the description is added as what was expected
    (jsonschema's own message names no alternative)."""
    errors = sorted(validator(schema_name).iter_errors(instance), key=lambda e: list(map(str, e.absolute_path)))
    if not errors:
        return None
    err = errors[0]
    message = _sized_message(err) or err.message
    if err.validator in ("anyOf", "oneOf") and isinstance(err.schema, dict) and err.schema.get("description"):
        message += f" (expected {err.schema['description']})"
    return json_path(err.absolute_path), message


#: A value whose ``repr`` is longer than this is not quoted in a size keyword's error (:func:`_sized_message`).
LONG_VALUE_CHARS = 80
#: Size keywords of JSON Schema whose errors name the count instead of quoting a long value (jsonschema's own
#: message quotes it: a 33-item list of paths fills the screen).
_SIZE_WORDS = {"maxItems": ("items", "more than the {} allowed"), "minItems": ("items", "fewer than the {} needed"),
               "maxLength": ("characters", "more than the {} allowed"),
               "maxProperties": ("keys", "more than the {} allowed")}


def _sized_message(err: Any) -> "str | None":
    """``"33 items, more than the 32 allowed"`` for a size keyword's error (:data:`_SIZE_WORDS`) on a value whose
    ``repr`` is longer than :data:`LONG_VALUE_CHARS`, else None (jsonschema's message, quoting it, is then kept)."""
    words = _SIZE_WORDS.get(err.validator)
    if words is None or not hasattr(err.instance, "__len__") or len(repr(err.instance)) <= LONG_VALUE_CHARS:
        return None
    return f"{len(err.instance)} {words[0]}, {words[1].format(err.validator_value)}"


#: At most this many specs are remembered as valid against their schema (:func:`validate`): a registry is built
#: again for every command, test and installed pack, and validating the same built-in specs (an environment's
#: trajectory is thousands of schema nodes) was most of its time.
SCHEMA_VALID_MEMO = 4096
_SCHEMA_VALID: dict[tuple["str | Path", bytes], None] = {}


def _exact_bytes(value: Any) -> bytes:
    """Bytes that equal another value's only when both are the same document with the same Python types (``True``
    is not ``1``, ``1`` is not ``1.0``, ``-0.0`` is not ``0.0``, a list is not a tuple, ``{1: x}`` is not
    ``{"1": x}``; mappings in their key order): ``marshal`` format version 0, which writes every string and float the
    same way in every process (no interning flags, no shared references; floats as their shortest exact text) and
    refuses subclasses of the built-in types (bytes-like values are written alike, and jsonschema judges them
    alike). Faster than walking the value in Python, which was a third of building the registry. Raises
    ValueError for a value ``marshal`` cannot write (its validation is then not remembered)."""
    return marshal.dumps(value, 0)


#: The file (in BenchBot's cache directory) of the specs found valid by earlier processes (:class:`ValidStore`);
#: named by its format, so that installations of two formats sharing a cache directory do not empty each other's.
VALID_STORE_FILE = "valid_specs_2.json"


class ValidStore:
    """The specs found valid by earlier processes, remembered across them: each command built its registry again and
    validated every installed spec against its schema (jsonschema's walk over the built-in environments' trajectories,
    0.1-0.15 s of README command 1 on the 2-core CPU). A spec is remembered by a SHA-256 digest of its exact value
    (:func:`_exact_bytes`: types and key order included), of its schema file's bytes and of jsonschema's version, so that
    a changed spec, schema or validator is validated again; only valid specs are stored (an invalid one is refused
    every time), at most :data:`SCHEMA_VALID_MEMO` (the oldest go first).

    The registry loads it (:func:`valid_store`) and saves what it added once it is built (:meth:`save`). The file
    is JSON ``{"format": 2, "digests": [hex, ...]}``, written atomically; one that cannot be read, or of another
    format (1: digests of another encoding of the value), counts as empty.

    Args:
        path: the store's file (default: :data:`VALID_STORE_FILE` in the cache directory).
    """

    FORMAT = 2

    def __init__(self, path: Path) -> None:
        self.path = path
        self.digests: dict[str, None] = {}
        self.added = False
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
            if isinstance(data, dict) and data.get("format") == self.FORMAT and isinstance(data.get("digests"), list):
                self.digests = {d: None for d in data["digests"] if isinstance(d, str)}
        except (OSError, ValueError):
            pass

    def __contains__(self, digest: str) -> bool:
        return digest in self.digests

    def add(self, digest: str) -> None:
        """Remember ``digest`` (saved by :meth:`save`)."""
        if digest not in self.digests:
            self.digests[digest] = None
            self.added = True

    def save(self) -> None:
        """Write the store when digests were added since it was read (the newest :data:`SCHEMA_VALID_MEMO`); a
        folder or file that cannot be written leaves it unsaved (the next process validates again)."""
        if not self.added:
            return
        from benchbot.core import atomic

        kept = list(self.digests)[-SCHEMA_VALID_MEMO:]
        try:
            atomic.write_json(self.path, {"format": self.FORMAT, "digests": kept})
            self.added = False
        except OSError:
            pass


_store: ValidStore | None = None


def valid_store(path: Path | None) -> ValidStore | None:
    """Validate with the store at ``path`` from now on in this process, or with none (``None``); returns the store
    (the one in use when it is at ``path`` already, else read now)."""
    global _store
    if path is None:
        _store = None
    elif _store is None or _store.path != path:
        _store = ValidStore(path)
    return _store


@functools.lru_cache(maxsize=None)
def _schema_identity(schema_name: "str | Path") -> str:
    """The SHA-256 of the schema file's bytes and jsonschema's version: what a stored digest depends on besides the
    spec. Raises OSError when the schema file cannot be read."""
    from importlib.metadata import PackageNotFoundError, version

    path = schema_name if isinstance(schema_name, Path) else schema_dir() / f"{schema_name}.schema.json"
    try:
        validator_version = version("jsonschema")
    except PackageNotFoundError:
        import jsonschema

        validator_version = jsonschema.__file__ or ""
    return hashlib.sha256(path.read_bytes() + b"\0" + validator_version.encode()).hexdigest()


def _stored_digest(schema_name: "str | Path", exact: bytes) -> str | None:
    """The digest of a spec (its :func:`_exact_bytes`) against ``schema_name`` in the :class:`ValidStore`; None
    when its schema file cannot be read (then the spec is validated, and its error says so)."""
    try:
        identity = _schema_identity(schema_name)
    except OSError:
        return None
    return hashlib.sha256(f"{identity}\0".encode() + exact).hexdigest()


def validate(instance: Any, schema_name: str, source: str) -> None:
    """Validate ``instance`` against ``schemas/<schema_name>.schema.json``. A spec found valid before is not walked
    again: in this process (:data:`_SCHEMA_VALID`) or, with the registry's store, in an earlier one
    (:class:`ValidStore`).

    A task's ``actions`` must also be actions the episode performs (:func:`check_task_actions`).

    Raises:
        SpecError: ``"<source>: <$.json.path>: <message>"`` for the first error (by path).
    """
    try:
        key = (schema_name, _exact_bytes(instance))
    except (ValueError, TypeError, RecursionError):  # a value marshal cannot write: validated every time
        key = None
    if key is None or key not in _SCHEMA_VALID:
        store = _store
        digest = _stored_digest(schema_name, key[1]) if key is not None and store is not None else None
        if digest is None or digest not in store:
            error = first_error(instance, schema_name)
            if error:
                raise SpecError(f"{source}: {error[0]}: {error[1]}",
                                f"fix the field to match schemas/{schema_name}.schema.json")
            if digest is not None:
                store.add(digest)
        if key is not None:
            if len(_SCHEMA_VALID) >= SCHEMA_VALID_MEMO:
                _SCHEMA_VALID.clear()
            _SCHEMA_VALID[key] = None
    if schema_name == "task":
        check_task_actions(instance, source)
    if schema_name == "evaluator":
        check_evaluator_scores(instance, source)


def check_evaluator_scores(spec: dict, source: str) -> None:
    """An evaluator's ``scores`` declaration (when it has one) names each score once and marks exactly one
    ``primary`` (docs/evaluation.md, "Declaring scores").

    Raises:
        SpecError: ``"<source>: $.scores: ..."`` naming the scores at fault.
    """
    scores = spec.get("scores") or []
    names = [s["name"] for s in scores]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise SpecError(f"{source}: $.scores: '{twice[0]}' is declared twice", "declare each score once")
    primary = [s["name"] for s in scores if s.get("primary")]
    if scores and len(primary) != 1:
        raise SpecError(f"{source}: $.scores: {len(primary)} scores are primary ({', '.join(primary) or 'none'})",
                        "mark exactly one score 'primary: true': the one that ranks, compares and summarises")


def check_task_actions(task: dict, source: str) -> None:
    """Every name in a task spec's ``actions`` must be one of :data:`benchbot.core.episode.ACTIONS` (else no robot
    could perform it; checked when the registry loads the spec and when ``benchbot install`` scans a pack).

    Raises:
        SpecError: ``"<source>: $.actions[i]: unknown action 'x' (did you mean …?)"``, or with the list of actions
            when no name is close (in the message, which ``benchbot install`` lists per file).
    """
    from benchbot.core.episode import ACTIONS

    for i, action in enumerate(task.get("actions") or []):
        if action not in ACTIONS:
            close = close_names(action, list(ACTIONS))
            guess = f" (did you mean {', '.join(close)}?)" if close else f" (the actions are {', '.join(ACTIONS)})"
            raise SpecError(f"{source}: $.actions[{i}]: unknown action '{action}'{guess}",
                            f"the actions are {', '.join(ACTIONS)}")


SPEC_SUFFIXES = (".yaml", ".yml", ".json")
"""The file suffixes of spec files that a folder returned by a content hook contributes."""


def expand_spec_folders(specs: list) -> list:
    """A content hook's list with every folder replaced by the spec files directly inside it.

    Args:
        specs: what a content hook returned: dicts, and paths (``str``/``Path``) of spec files or of folders.

    Returns:
        The same items in order, a folder replaced by its files whose suffix is in :data:`SPEC_SUFFIXES`, sorted by
        name (not recursive); a folder with none stays as it is, so that loading it reports the folder by name.
    """
    out: list = []
    for raw in specs:
        if isinstance(raw, (str, Path)) and Path(raw).is_dir():
            files = sorted(p for p in Path(raw).iterdir() if p.suffix in SPEC_SUFFIXES and p.is_file())
            out.extend(files or [raw])
        else:
            out.append(raw)
    return out


def load_spec_file(path: Path) -> dict:
    """Parse a YAML or JSON spec file into a dict, read by :mod:`benchbot.core.safe_load`
    (within :data:`~benchbot.core.limits.MAX_SPEC_BYTES`, no YAML aliases, bounded nesting and integers).

    Raises:
        SpecError: the file is missing, unreadable, too large, not UTF-8, malformed, or not a mapping (one line
            naming the file).
    """
    data = load_data_file(Path(path), MAX_SPEC_BYTES, SpecError)
    if not isinstance(data, dict):
        raise SpecError(f"{path}: expected a mapping at the top level, got {type(data).__name__}", "")
    return data


@dataclass
class Entry:
    """One registered spec.

    Attributes:
        kind: the registry kind (``tasks``, ``environments``, ...).
        name: its index name (``name`` field; ``name:variant`` for environments and ground truths).
        spec: the validated spec (dict). File specs get ``_file_path`` (absolute path) as in the original.
        plugin: the name of the plugin that contributed it.
        path: the spec's file, or ``None`` when a plugin gave a dict.
        override: it comes from a content pack installed with ``--override`` and replaces another source's spec of
            the same name.
    """

    kind: str
    name: str
    spec: dict
    plugin: str
    path: Path | None
    override: bool = False


def singular(kind: str) -> str:
    """``tasks`` → ``task``, ``batches`` → ``batch``, ``ground_truths`` → ``ground truth``."""
    return {"batches": "batch"}.get(kind, kind[:-1]).replace("_", " ")


def entry_name(kind: str, spec: dict) -> str:
    """The index name of a spec of ``kind``."""
    if kind == "environments":
        return f"{spec['name']}:{spec['variant']}"
    if kind == "ground_truths":
        return f"{spec['environment']['name']}:{spec['environment']['variant']}"
    return str(spec["name"])
