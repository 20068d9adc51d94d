"""An MCAP file cut short (a ROS 2 recorder killed before it closed the file: no summary, no
footer), read up to its cut: a copy of its complete records with an end of its own, which
rosbags reads by scanning it (a footer without a summary). rosbags alone refused it ("File end
magic is invalid"), the whole recording lost for its last, unfinished chunk."""

from __future__ import annotations

import shutil
from pathlib import Path

from homemodel.core.errors import InputError

MAGIC = b"\x89MCAP0\r\n"
_DATA_END, _FOOTER = 0x0F, 0x02
# A footer pointing at no summary: opcode, length 20, summary start 0, summary offset start 0, CRC 0.
_EMPTY_FOOTER = bytes([_FOOTER]) + (20).to_bytes(8, "little") + bytes(8 + 8 + 4) + MAGIC


def is_cut_short(path: Path) -> bool:
    """An MCAP file (by its first bytes) without the magic that ends a closed one."""
    size = path.stat().st_size
    with path.open("rb") as file:
        head = file.read(len(MAGIC))
        file.seek(max(size - len(MAGIC), 0))
        return head == MAGIC and (size < 2 * len(MAGIC) or file.read() != MAGIC)


def complete_records_end(path: Path) -> tuple[int, int]:
    """Where the last record that the file holds whole ends (records: an opcode byte, a uint64
    length, the content), before any data-end or footer record; and how many there are."""
    size = path.stat().st_size
    end, records = len(MAGIC), 0
    with path.open("rb") as file:
        file.seek(end)
        while (head := file.read(9)) and len(head) == 9:
            opcode, length = head[0], int.from_bytes(head[1:], "little")
            if opcode in (_DATA_END, _FOOTER) or end + 9 + length > size:
                break
            end, records = end + 9 + length, records + 1
            file.seek(end)
    return end, records


def recovered_copy(path: Path, folder: Path) -> tuple[Path, int]:
    """A copy in `folder` (same name) of the cut MCAP file at `path` holding its complete
    records and an empty footer; and the bytes of the unfinished last record left out. Refuses
    a file cut before any record past its header (the topics are in the first chunk)."""
    end, records = complete_records_end(path)
    if records < 2:
        raise InputError(f"{path}: cut short before its first complete chunk: nothing to read (`mcap recover` it)")
    copy = folder / path.name
    with path.open("rb") as source, copy.open("wb") as target:
        remaining = end
        while remaining > 0:
            block = source.read(min(remaining, 1 << 20))
            target.write(block)
            remaining -= len(block)
        target.write(_EMPTY_FOOTER)
    return copy, path.stat().st_size - end


def remove_copies(folder: Path | None) -> None:
    if folder is not None:
        shutil.rmtree(folder, ignore_errors=True)
