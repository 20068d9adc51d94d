"""`poses.json`: `camera_from_table` per frame (and the true poses a simulation writes).

```json
{"convention": "...",
 "frames": [{"frame": "000000", "camera_from_table": [[4 x 4]], ...per-frame figures}],
 "skipped": [{"frame": "000007", "reason": "2 tags seen, 3 needed"}]}
```
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from homemodel.core.atomic import write_json
from homemodel.core.errors import InputError
from homemodel.core.input_files import read_bounded

CONVENTION = (
    "camera_from_table maps table-frame points (board frame, z up out of the table top, metres) "
    "to the camera frame (OpenCV: x right, y down, z forward)"
)


def write_poses(
    path: Path,
    camera_from_table: dict[str, np.ndarray],
    *,
    figures: dict[str, dict[str, Any]] | None = None,
    skipped: dict[str, str] | None = None,
) -> None:
    frames = []
    for stem in sorted(camera_from_table):
        entry: dict[str, Any] = {"frame": stem, "camera_from_table": np.round(camera_from_table[stem], 9).tolist()}
        entry.update((figures or {}).get(stem, {}))
        frames.append(entry)
    document = {
        "convention": CONVENTION,
        "frames": frames,
        "skipped": [{"frame": s, "reason": r} for s, r in sorted((skipped or {}).items())],
    }
    write_json(Path(path), document)


def read_poses(path: Path) -> dict[str, np.ndarray]:
    """`camera_from_table` by frame stem."""
    path = Path(path)
    try:
        document = json.loads(read_bounded(path, 64 * 1024 * 1024))
        poses = {str(f["frame"]): np.asarray(f["camera_from_table"], dtype=np.float64) for f in document["frames"]}
    except (ValueError, KeyError, TypeError, RecursionError) as exc:  # RecursionError: [[[[... nested deep
        raise InputError(f"{path}: not a poses file: {type(exc).__name__}: {exc}") from None
    for stem, pose in poses.items():
        if pose.shape != (4, 4) or not np.all(np.isfinite(pose)):
            raise InputError(f"{path}: frame {stem}: camera_from_table is not a finite 4x4 matrix")
    return poses
