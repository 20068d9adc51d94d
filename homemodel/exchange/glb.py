"""The GLB container (binary glTF 2.0): a 12-byte header, a JSON chunk, an optional BIN chunk.

One reader for every command that opens a .glb: the version and every chunk's bounds are
checked, so a corrupt file is one InputError naming what is wrong, never an IndexError later.
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass
from typing import Any

from homemodel.core.errors import InputError

GLB_MAGIC = b"glTF"
GLB_VERSION = 2
JSON_CHUNK = 0x4E4F534A
BIN_CHUNK = 0x004E4942
_HEADER_BYTES = 12
_CHUNK_HEADER_BYTES = 8


@dataclass(frozen=True)
class Glb:
    """A GLB's JSON document and its binary buffer (empty when the file has none)."""

    doc: dict[str, Any]
    blob: bytes


def _chunk(data: bytes, offset: int, end: int, what: str) -> tuple[int, bytes]:
    if offset + _CHUNK_HEADER_BYTES > end:
        raise InputError(f"the {what} chunk's header runs past the file's end")
    length, kind = struct.unpack_from("<II", data, offset)
    start = offset + _CHUNK_HEADER_BYTES
    if start + length > end:
        raise InputError(f"the {what} chunk ({length} bytes) runs past the file's end")
    return kind, data[start : start + length]


def read_glb(data: bytes) -> Glb:
    """The chunks of a GLB file's bytes; raises InputError (without the file's name, for the
    caller to prefix) when the header, the version or a chunk's bounds are wrong."""
    if len(data) < _HEADER_BYTES + _CHUNK_HEADER_BYTES:
        raise InputError(f"{len(data)} bytes is too short for a GLB")
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    if magic != GLB_MAGIC or version != GLB_VERSION:
        raise InputError(f"not a glTF 2.0 binary (magic {magic!r}, version {version})")
    if length > len(data):
        raise InputError(f"the header says {length} bytes but the file has {len(data)}")
    kind, text = _chunk(data, _HEADER_BYTES, length, "JSON")
    if kind != JSON_CHUNK:
        raise InputError("the first chunk is not a JSON chunk")
    try:
        doc = json.loads(text.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"the JSON chunk does not parse: {exc}") from None
    if not isinstance(doc, dict):
        raise InputError("the JSON chunk is not an object")
    blob = b""
    offset = _HEADER_BYTES + _CHUNK_HEADER_BYTES + len(text)
    if offset < length:
        kind, blob = _chunk(data, offset, length, "BIN")
        if kind != BIN_CHUNK:
            raise InputError(f"the second chunk is not a BIN chunk (type {kind:#x})")
    return Glb(doc, blob)


def pack_glb(doc: dict[str, Any], blob: bytes = b"") -> bytes:
    """A GLB file's bytes: compact JSON padded with spaces, the buffer with zeros, to 4 bytes."""
    text = json.dumps(doc, separators=(",", ":"), ensure_ascii=False).encode("utf-8")
    text += b" " * (-len(text) % 4)
    chunks = struct.pack("<II", len(text), JSON_CHUNK) + text
    if blob:
        blob = blob + b"\0" * (-len(blob) % 4)
        chunks += struct.pack("<II", len(blob), BIN_CHUNK) + blob
    return struct.pack("<4sII", GLB_MAGIC, GLB_VERSION, _HEADER_BYTES + len(chunks)) + chunks
