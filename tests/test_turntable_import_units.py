"""A recording whose depth is not in its format's units, told with --depth-units-m: the
simulated box's TUM recording (tests/test_turntable_recordings.py) written again in mm, as a
user's own script saves a RealSense's depth into TUM's layout (TUM's are 1/5000 m). Refused
without the flag, naming it; imported with it, reconstructed to the truth."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import trimesh
from test_turntable_recordings import ACCURACY_RATIO, _reconstruct, baseline_mm, clean, made, recordings  # noqa: F401
from typer.testing import CliRunner

from homemodel.cli import app
from homemodel.evaluation import mean_surface_distance_m
from homemodel.geometry.camera import load_camera, save_camera


def _in_mm(tum: Path, folder: Path) -> Path:
    """A copy of the TUM folder whose depth PNGs hold mm (the lists and colour unchanged)."""
    import cv2

    shutil.copytree(tum, folder)
    for path in (folder / "depth").iterdir():
        fifths = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        assert fifths.dtype == np.uint16
        cv2.imwrite(str(path), np.round(fifths / 5).astype(np.uint16))
    return folder


@pytest.mark.slow
def test_a_tum_folder_in_mm_imports_with_its_units_given(
    clean: Path, baseline_mm: float, recordings: dict, tmp_path: Path  # noqa: F811
) -> None:
    path, rig = recordings["tum"]
    scan = _in_mm(path, tmp_path / "scan")
    save_camera(rig.color_camera, tmp_path / "camera.yaml")
    args = ["turntable", "import", str(scan), "--board", str(clean / "board.yaml"), "--camera", str(tmp_path / "camera.yaml")]
    refused = CliRunner().invoke(app, [*args, "--out", str(tmp_path / "refused")])
    assert refused.exit_code == 2 and "in 1 mm units it would fit (--depth-units-m 0.001)" in refused.output, refused.output
    assert not (tmp_path / "refused").exists()
    result = CliRunner().invoke(app, [*args, "--depth-units-m", "0.001", "--out", str(tmp_path / "capture")])
    assert result.exit_code == 0, result.output
    assert load_camera(tmp_path / "capture" / "camera.yaml").depth_scale_m == pytest.approx(0.001)
    reconstruction = _reconstruct(tmp_path / "capture")
    distance_mm = 1000 * mean_surface_distance_m(reconstruction.mesh, trimesh.load(clean / "ground_truth.ply", force="mesh"))
    assert distance_mm <= ACCURACY_RATIO * baseline_mm, f"{distance_mm:.3f} mm against the baseline's {baseline_mm:.3f} mm"
