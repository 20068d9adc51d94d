"""Save and load a trained `ShapeCompleter` (joblib) with its format version and fingerprint.

A model file is a pickle: load only model files you made or trust.
"""

from __future__ import annotations

import io
from pathlib import Path

import joblib

from homemodel.core.atomic import write_bytes_atomic
from homemodel.core.errors import InputError
from homemodel.core.input_files import read_bounded
from shape_completion.library import training_fingerprint
from shape_completion.pipeline import ShapeCompleter

FORMAT = "homemodel-shape-completion"
FORMAT_VERSION = 3
MAX_MODEL_BYTES = 4 * 1024**3


def save_model(completer: ShapeCompleter, path: Path) -> None:
    """Write the fitted completer atomically, with the format version and its fingerprints."""
    payload = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "fingerprint": completer.fingerprint_,
        "library_fingerprint": completer.library_fingerprint_,
        "completer": completer,
    }
    buffer = io.BytesIO()
    joblib.dump(payload, buffer, compress=3)
    write_bytes_atomic(Path(path), buffer.getvalue())


def load_model(path: Path, *, library_fingerprint: str | None = None) -> ShapeCompleter:
    """The completer in `path`; refuses another format version, a payload whose fingerprint does
    not fit its options, and (when given) a model trained on another library version."""
    path = Path(path)
    data = read_bounded(path, MAX_MODEL_BYTES)
    try:
        payload = joblib.load(io.BytesIO(data))
    except Exception as exc:  # a truncated or foreign file fails in many ways inside pickle
        raise InputError(f"{path}: not a completion model file ({type(exc).__name__})") from None
    if not isinstance(payload, dict) or payload.get("format") != FORMAT:
        raise InputError(f"{path}: not a completion model file")
    if payload.get("format_version") != FORMAT_VERSION:
        raise InputError(
            f"{path}: model format version {payload.get('format_version')}, this homemodel reads version"
            f" {FORMAT_VERSION}: train it again"
        )
    completer = payload.get("completer")
    if not isinstance(completer, ShapeCompleter) or payload.get("fingerprint") != training_fingerprint(
        payload.get("library_fingerprint", ""), completer.get_params()
    ):
        raise InputError(f"{path}: the model's fingerprint does not match its contents: train it again")
    if library_fingerprint is not None and payload["library_fingerprint"] != library_fingerprint:
        raise InputError(f"{path}: trained on another version of the library: train it again on this one")
    return completer
