"""Reading untrusted YAML, JSON and zip files within explicit limits.

Spec files (content packs, plugins' spec files) and results files (``benchbot eval``) come from other people. Every
reader here bounds what one file can cost before anything walks it, within the limits of
:mod:`benchbot.core.limits` (:data:`~benchbot.core.limits.MAX_SPEC_BYTES`,
:data:`~benchbot.core.limits.MAX_RESULTS_BYTES`, :data:`~benchbot.core.limits.MAX_ZIP_BYTES`,
:data:`~benchbot.core.limits.MAX_ZIP_MEMBERS`, :data:`~benchbot.core.limits.MAX_NESTING_DEPTH`: defaults, variables
and byte suffixes there).

YAML aliases (``*name``, including ``<<: *name`` merges) are refused in spec files: a few hundred bytes of nested
aliases expand to billions of nodes. Integers longer than Python's ``sys.get_int_max_str_digits()`` (4300 digits)
and text that is not UTF-8 are refused too. Each refusal is one :class:`~benchbot.core.errors.BenchbotError` naming the
file, the limit and how to raise it; nothing here lets a ``RecursionError``, ``ValueError`` or
``UnicodeDecodeError`` escape. What is not a regular file is said to be what it is (:func:`path_kind`: a folder,
a FIFO, a device), found without waiting on a FIFO; a file named ``.zip`` that is no zip archive, and a damaged
zip archive, are said to be so (:func:`is_zip_archive`), not "not valid JSON".
"""

from __future__ import annotations

import json
import os
import stat
import sys
import zipfile
from pathlib import Path
from typing import Any, Iterator

import yaml

from benchbot.core.errors import BenchbotError
from benchbot.core.limits import (
    MAX_NESTING_DEPTH, MAX_RESULTS_BYTES, MAX_ZIP_BYTES, MAX_ZIP_MEMBERS, Limit, human_bytes,
)


def _file_hint(limit: Limit) -> str:
    return f"if the file is genuine, {limit.hint()}"


def _too_big(source: str, size: int | str, limit: Limit, what: str, error: type[BenchbotError]) -> BenchbotError:
    size_text = human_bytes(size) if isinstance(size, int) else size
    return error(f"{source}: {what} is {size_text}, more than the limit of {limit.describe()} "
                 f"({limit.raise_hint()})", _file_hint(limit))


_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a named pipe (FIFO)"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


def file_kind(mode: int) -> str:
    """What a file of ``st_mode`` ``mode`` is, for messages: ``a regular file``, ``a folder``, ``a named pipe
    (FIFO)``, ``a character device`` (``/dev/zero``), ``a block device``, ``a socket``."""
    for test, name in _KINDS:
        if test(mode):
            return name
    return "a regular file" if stat.S_ISREG(mode) else "not a regular file"


def path_kind(path: Path) -> str:
    """What ``path`` is (symlinks followed), found without opening it (so a FIFO is never waited on): ``missing``,
    ``a broken symbolic link``, or :func:`file_kind` of it; ``cannot read: <why>`` when it cannot be looked at."""
    try:
        return file_kind(os.stat(path).st_mode)
    except FileNotFoundError:
        return "a broken symbolic link" if os.path.islink(path) else "missing"
    except OSError as exc:
        return f"cannot read: {exc.strerror or exc}"


_ZIP_MAGIC = (b"PK\x03\x04", b"PK\x05\x06", b"PK\x07\x08")
"""How a zip archive starts: a local file header, an empty archive's end record, a spanned archive's marker."""


def is_zip_archive(path: Path, error: type[BenchbotError]) -> bool:
    """Whether the file ``path`` is a zip archive (it has a zip end-of-archive record), opened without blocking.

    A file that is not one is ``False`` (read it as JSON) unless it pretends to be one, which is refused rather
    than reported as "not valid JSON".

    Raises:
        ``error``: ``path`` is not a regular file (saying what it is); is named ``.zip`` but is no zip archive;
            starts as a zip archive but has no end record (``a damaged zip archive``: truncated, say); cannot be
            read.
    """
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        with os.fdopen(fd, "rb") as f:
            mode = os.fstat(f.fileno()).st_mode
            if not stat.S_ISREG(mode):
                raise error(f"{path}: {file_kind(mode)}, not a regular file",
                            "give a file (not a pipe, device or folder)")
            head = f.read(4)
            f.seek(0)
            found = zipfile.is_zipfile(f)
    except OSError as exc:
        raise error(f"{path}: cannot read: {exc.strerror or exc}", "check the path and its permissions") from None
    if found:
        return True
    if head in _ZIP_MAGIC:
        raise error(f"{path}: a damaged zip archive (it starts as one but has no end-of-archive record: truncated?)",
                    "re-create it with zip or shutil.make_archive")
    if path.suffix.lower() == ".zip":
        shown = "empty" if not head else f"it starts with {head!r}"
        raise error(f"{path}: not a zip archive, though named .zip ({shown})",
                    "give the zip archive itself, or name a JSON results file .json")
    return False


def read_capped(path: Path, limit: Limit, error: type[BenchbotError], what: str = "the file") -> bytes:
    """The bytes of the regular file ``path``, refusing it (from its size, before reading) when it is larger than
    ``limit``; at most ``limit + 1`` bytes are ever read, even if the file grows meanwhile.

    Raises:
        ``error``: the file is too large (naming the limit and its variable) or cannot be read.
    """
    cap = limit.value()
    try:
        # O_NONBLOCK: opening a FIFO (say, one in a content pack) must not wait for a writer; it is refused below
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        with os.fdopen(fd, "rb") as f:
            info = os.fstat(f.fileno())
            if not stat.S_ISREG(info.st_mode):
                raise error(f"{path}: {file_kind(info.st_mode)}, not a regular file",
                            "give a file (not a pipe, device or folder)")
            size = info.st_size
            if size > cap:
                raise _too_big(str(path), size, limit, what, error)
            data = f.read(cap + 1)
    except OSError as exc:
        raise error(f"{path}: cannot read: {exc.strerror or exc}", "check the path and its permissions") from None
    if len(data) > cap:
        raise _too_big(str(path), f"over {human_bytes(cap)}", limit, what, error)
    return data


def check_depth(data: Any, source: str, error: type[BenchbotError]) -> None:
    """Refuse ``data`` (parsed JSON/YAML) when lists/dicts nest deeper than :data:`MAX_NESTING_DEPTH`
    (iterative: never recurses, whatever the depth; every node is visited once, so a shared node counts per
    reference).

    Raises:
        ``error``: naming the source, the limit and its variable.
    """
    cap = MAX_NESTING_DEPTH.value()
    stack: list[tuple[Any, int]] = [(data, 1)]
    while stack:
        node, depth = stack.pop()
        if isinstance(node, dict):
            children = node.values()
        elif isinstance(node, list):
            children = node
        else:
            continue
        if depth > cap:
            raise _too_deep(source, error)
        stack.extend((child, depth + 1) for child in children if isinstance(child, (dict, list)))


def _too_deep(source: str, error: type[BenchbotError]) -> BenchbotError:
    cap = MAX_NESTING_DEPTH.value()
    return error(f"{source}: lists/objects are nested more than {cap} levels deep ({MAX_NESTING_DEPTH.raise_hint()})",
                 _file_hint(MAX_NESTING_DEPTH))


def _number_too_long(source: str, error: type[BenchbotError]) -> BenchbotError:
    return error(f"{source}: a number has more than {sys.get_int_max_str_digits()} digits",
                 "write it with fewer digits (or as a float)")


def _decode(source: str, data: bytes, error: type[BenchbotError]) -> str:
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise error(f"{source}: not UTF-8 text (invalid byte 0x{data[exc.start]:02x} at offset {exc.start})",
                    "save the file as UTF-8") from None


def parse_json(source: str, data: bytes | str, error: type[BenchbotError]) -> Any:
    """Parse JSON text, refusing non-UTF-8 bytes, deep nesting and over-long integers with one-line errors.

    Args:
        source: names the file in messages (a path, or ``archive.zip:member``).
        data: the file's bytes (UTF-8, a BOM allowed) or text.
        error: the error class to raise (``SpecError`` for specs, ``ResultsError`` for results).

    Raises:
        ``error``: ``"<source>: not valid JSON (line L column C: ...)"``, not UTF-8, nested too deep, or a number
            with too many digits.
    """
    text = _decode(source, data, error) if isinstance(data, (bytes, bytearray)) else data
    try:
        value = json.loads(text)
    except json.JSONDecodeError as exc:
        raise error(f"{source}: not valid JSON (line {exc.lineno} column {exc.colno}: {exc.msg})",
                    "fix the syntax, or write the file with json.dump") from None
    except RecursionError:
        raise _too_deep(source, error) from None
    except ValueError as exc:  # int(...) over sys.get_int_max_str_digits()
        if "digits" in str(exc):
            raise _number_too_long(source, error) from None
        raise error(f"{source}: not valid JSON ({str(exc).splitlines()[0]})", "fix the file") from None
    check_depth(value, source, error)
    return value


class _BoundedLoader(yaml.SafeLoader):
    """PyYAML's safe loader (pure Python: its composer recurses in Python, so depth is checked, never a C stack)
    without aliases and with a nesting limit."""

    def __init__(self, stream: str, max_depth: int) -> None:
        super().__init__(stream)
        self._max_depth = max_depth
        self._depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        if self.check_event(yaml.AliasEvent):
            mark = self.peek_event().start_mark
            raise _AliasRefused(mark.line + 1)
        if self.check_event(yaml.ScalarEvent):  # a leaf: only lists/mappings are levels, as in check_depth
            return super().compose_node(parent, index)
        self._depth += 1
        try:
            if self._depth > self._max_depth:
                raise _DepthRefused()
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


class _AliasRefused(Exception):
    def __init__(self, line: int) -> None:
        super().__init__(line)
        self.line = line


class _DepthRefused(Exception):
    pass


def parse_yaml(source: str, data: bytes | str, error: type[BenchbotError]) -> Any:
    """Parse one YAML document safely: no Python tags, no aliases, bounded nesting, bounded integers.

    Args:
        source: names the file in messages.
        data: the file's bytes (UTF-8, a BOM allowed) or text.
        error: the error class to raise.

    Raises:
        ``error``: ``"<source>: not valid YAML (line L)"``, an alias (``*name``) with its line, not UTF-8, nested
            deeper than :data:`MAX_NESTING_DEPTH`, or a number with too many digits.
    """
    text = _decode(source, data, error) if isinstance(data, (bytes, bytearray)) else data
    loader = _BoundedLoader(text, MAX_NESTING_DEPTH.value())
    try:
        return loader.get_single_data()
    except _AliasRefused as exc:
        raise error(f"{source}: YAML aliases (*name) are not allowed in spec files (line {exc.line})",
                    "write the value out instead of referring to an anchor") from None
    except (_DepthRefused, RecursionError):
        raise _too_deep(source, error) from None
    except yaml.YAMLError as exc:
        where = getattr(exc, "problem_mark", None)
        line = f" (line {where.line + 1})" if where is not None else ""
        raise error(f"{source}: not valid YAML{line}", "fix the syntax") from None
    except ValueError as exc:  # int(...) over sys.get_int_max_str_digits()
        if "digits" in str(exc):
            raise _number_too_long(source, error) from None
        raise error(f"{source}: not valid YAML ({str(exc).splitlines()[0]})", "fix the file") from None
    finally:
        loader.dispose()


def load_data_file(path: Path, limit: Limit, error: type[BenchbotError]) -> Any:
    """Read and parse a ``.json`` file as JSON, anything else as YAML, within ``limit`` bytes.

    Raises:
        ``error``: see :func:`read_capped`, :func:`parse_json` and :func:`parse_yaml`.
    """
    data = read_capped(path, limit, error)
    parse = parse_json if path.suffix == ".json" else parse_yaml
    return parse(str(path), data, error)


def zip_members(path: Path, error: type[BenchbotError], skip: Any = None) -> Iterator[tuple[str, bytes]]:
    """``(member name, bytes)`` of each file in the zip archive ``path``, one at a time, within the limits.

    Before anything is decompressed: the archive's size on disk must be within :data:`MAX_ZIP_BYTES`, its entry
    count (from the end record, then the central directory) within :data:`MAX_ZIP_MEMBERS`, and each member's
    declared size within :data:`MAX_RESULTS_BYTES`. While decompressing, the bytes actually produced are counted
    too (a header may lie): a member stops at :data:`MAX_RESULTS_BYTES` + 1 bytes and the archive at
    :data:`MAX_ZIP_BYTES` in all. Memory stays bounded by one member.

    Args:
        path: the archive.
        error: the error class to raise.
        skip: ``skip(name) -> bool`` for members not to read (folders are always skipped).

    Raises:
        ``error``: a limit is exceeded (naming it and its variable), or the archive is corrupt or unreadable.
    """
    total_cap, member_cap, count_cap = MAX_ZIP_BYTES.value(), MAX_RESULTS_BYTES.value(), MAX_ZIP_MEMBERS.value()
    try:
        size = path.stat().st_size
    except OSError as exc:
        raise error(f"{path}: cannot read: {exc.strerror or exc}", "check the path") from None
    if size > total_cap:
        raise _too_big(str(path), size, MAX_ZIP_BYTES, "the zip archive", error)
    try:
        with open(path, "rb") as f:
            end = zipfile._EndRecData(f)  # type: ignore[attr-defined]  # the entry count, before parsing entries
        declared = end[zipfile._ECD_ENTRIES_TOTAL] if end else 0  # type: ignore[attr-defined]
    except (OSError, AttributeError, IndexError, TypeError):
        declared = 0
    if declared > count_cap:
        raise _too_many(path, declared, error)
    produced = 0
    try:
        with zipfile.ZipFile(path) as archive:
            infos = archive.infolist()
            if len(infos) > count_cap:
                raise _too_many(path, len(infos), error)
            for info in infos:
                if info.is_dir() or (skip is not None and skip(info.filename)):
                    continue
                source = f"{path}:{info.filename}"
                if info.file_size > member_cap:
                    raise _too_big(source, info.file_size, MAX_RESULTS_BYTES, "the member (decompressed)", error)
                if produced + info.file_size > total_cap:
                    raise _too_big(str(path), f"over {human_bytes(total_cap)} decompressed", MAX_ZIP_BYTES,
                                   "the zip archive", error)
                chunks, got = [], 0
                with archive.open(info) as member:
                    while chunk := member.read(min(1 << 20, member_cap + 1 - got)):
                        chunks.append(chunk)
                        got += len(chunk)
                        if got > member_cap:  # the header lied about the size
                            raise _too_big(source, f"over {human_bytes(member_cap)}", MAX_RESULTS_BYTES,
                                           "the member (decompressed)", error)
                        if produced + got > total_cap:
                            raise _too_big(str(path), f"over {human_bytes(total_cap)} decompressed", MAX_ZIP_BYTES,
                                           "the zip archive", error)
                produced += got
                yield info.filename, b"".join(chunks)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, NotImplementedError, EOFError, OSError, RuntimeError) as exc:
        why = str(exc)
        if "CRC" in why:  # zipfile inflates no further than the header's size, so a lying header ends in a bad CRC
            why += ": a member's content does not match its header (a damaged or crafted archive)"
        raise error(f"{path}: a damaged zip archive, cannot read it ({why})",
                    "re-create it with zip or shutil.make_archive") from None


def _too_many(path: Path, count: int, error: type[BenchbotError]) -> BenchbotError:
    return error(f"{path}: the zip archive has {count} entries, more than the limit of "
                 f"{MAX_ZIP_MEMBERS.describe()} ({MAX_ZIP_MEMBERS.raise_hint()})", _file_hint(MAX_ZIP_MEMBERS))
