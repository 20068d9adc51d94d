"""Arrays in a `.npz` file, written atomically and read without running code or over-allocating.

A pickle (joblib, `np.load(allow_pickle=True)`) runs whatever code its author put in it; an
`.npz` read here holds numbers only: object arrays are refused, every member's header is
checked against its size in the zip before an array is allocated, and the total is bounded.
"""

from __future__ import annotations

import io
import zipfile
from pathlib import Path

import numpy as np

from homemodel.core.atomic import write_bytes_atomic
from homemodel.core.errors import InputError
from homemodel.core.limits import Limit

ZIP_MAGIC = b"PK\x03\x04"


def write_npz(path: Path, arrays: dict[str, np.ndarray], *, overwrite: bool = True, compressed: bool = True) -> None:
    """`.npz` of numeric arrays, written atomically (`overwrite=False`: never over a file);
    `compressed=False` for files read often, where inflating costs more than the bytes save."""
    for key, array in arrays.items():
        if np.asarray(array).dtype.hasobject:
            raise ValueError(f"{key}: object arrays cannot be stored without pickle")
    buffer = io.BytesIO()
    (np.savez_compressed if compressed else np.savez)(buffer, **arrays)
    write_bytes_atomic(Path(path), buffer.getvalue(), overwrite=overwrite)


def _read_member(archive: zipfile.ZipFile, info: zipfile.ZipInfo, source: str) -> np.ndarray:
    with archive.open(info) as f:
        version = np.lib.format.read_magic(f)
        if version == (1, 0):
            shape, fortran, dtype = np.lib.format.read_array_header_1_0(f)
        elif version == (2, 0):
            shape, fortran, dtype = np.lib.format.read_array_header_2_0(f)
        else:
            raise ValueError(f"npy version {version}")
        if dtype.hasobject:
            raise InputError(f"{source}: {info.filename} holds Python objects, which homemodel never loads")
        nbytes = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
        if nbytes > info.file_size - f.tell():
            raise ValueError(f"{info.filename}: its header claims more data than the member holds")
        data = f.read(nbytes)
    if len(data) != nbytes:
        raise ValueError(f"{info.filename}: truncated")
    array = np.frombuffer(data, dtype=dtype).reshape(shape, order="F" if fortran else "C")
    return array.copy()  # writable, and free of the read buffer


def read_npz(path: Path, limit: Limit) -> dict[str, np.ndarray]:
    """The arrays of `path`; refuses a file that is not a zip before reading it further, any
    member that is not a numeric `.npy`, and more than `limit` bytes of arrays in all."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file" if not path.exists() else f"{path}: not a regular file")
    try:
        with path.open("rb") as f:
            head = f.read(len(ZIP_MAGIC))
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror}") from None
    if head != ZIP_MAGIC:
        raise InputError(f"{path}: not an .npz array file (a pickle or another format is never loaded)")
    try:
        with zipfile.ZipFile(path) as archive:
            members = archive.infolist()
            limit.check(path, sum(info.file_size for info in members))
            arrays = {}
            for info in members:
                if not info.filename.endswith(".npy"):
                    raise InputError(f"{path}: {info.filename} is not an array")
                arrays[info.filename[: -len(".npy")]] = _read_member(archive, info, str(path))
    except InputError:
        raise
    except (zipfile.BadZipFile, ValueError, OSError, EOFError, RuntimeError, NotImplementedError) as exc:
        raise InputError(f"{path}: not a readable .npz array file ({exc})") from None
    return arrays
