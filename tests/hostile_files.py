"""Builders of hostile files, shared by the security tests (``tests/test_security_files.py``) and the benchmark
``benchmarks/hostile_inputs.py``: a zip bomb (optionally with a header that lies about its size) and a YAML alias
bomb ("billion laughs")."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path


def zip_bomb(path: Path, name: str, size: int, declared: int | None = None) -> Path:
    """A zip archive whose one deflated member ``name`` decompresses to ``size`` zero bytes (a ~1000:1 bomb, built
    in a fraction of a second by repeating one fully flushed deflate block); the headers claim ``declared`` bytes
    (default: the truth)."""
    chunk = 1 << 24
    assert size % chunk == 0
    block = zlib.compressobj(9, zlib.DEFLATED, -15)
    one = block.compress(b"\0" * chunk) + block.flush(zlib.Z_FULL_FLUSH)
    data = one * (size // chunk) + zlib.compressobj(9, zlib.DEFLATED, -15).flush()
    crc = 0
    for _ in range(size // chunk):
        crc = zlib.crc32(b"\0" * chunk, crc)
    declared = size if declared is None else declared
    fname = name.encode()
    local = struct.pack("<4s5H3L2H", b"PK\x03\x04", 20, 0, 8, 0, 0, crc, len(data), declared, len(fname), 0)
    central = struct.pack("<4s6H3L5H2L", b"PK\x01\x02", 20, 20, 0, 8, 0, 0, crc, len(data), declared, len(fname),
                          0, 0, 0, 0, 0, 0)
    offset = len(local) + len(fname) + len(data)
    end = struct.pack("<4s4H2LH", b"PK\x05\x06", 0, 0, 1, 1, len(central) + len(fname), offset, 0)
    path.write_bytes(local + fname + data + central + fname + end)
    return path


def alias_bomb(levels: int = 12) -> str:
    """The billion-laughs YAML: ``levels`` anchors of 9 aliases each; ``actions`` (which the schema checks item by
    item) is 9**levels strings from ~600 bytes."""
    lines = ['a0: &a0 ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    for i in range(1, levels):
        lines.append(f"a{i}: &a{i} [" + ",".join([f"*a{i - 1}"] * 9) + "]")
    return "name: bomb\nobservations: [poses]\n" + "\n".join(lines) + f"\nactions: *a{levels - 1}\n"
