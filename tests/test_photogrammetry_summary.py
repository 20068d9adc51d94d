"""What photogrammetry's summary.json says of a model's size: a mass only when markers made it metric."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import trimesh

from photogrammetry.metric_frame import ModelFrame
from photogrammetry.pipeline import Reconstruction, ReconstructOptions, write_reconstruction
from photogrammetry.texturing import TexturedMesh


def _reconstruction(scaled: bool, work_dir: Path) -> Reconstruction:
    """A textured 0.2 x 0.1 x 0.3 box as the pipeline hands it to the export (no photos needed)."""
    mesh = trimesh.creation.box(extents=(0.2, 0.1, 0.3))
    textured = TexturedMesh(
        mesh=mesh,
        uv=np.zeros((len(mesh.vertices), 2)),
        texture=np.full((8, 8, 3), 128, np.uint8),
        covered_share=1.0,
    )
    frame = ModelFrame(model_from_sfm=np.eye(4), scale=1.0, scaled=scaled, levelled=True)
    figures = {"scaled": scaled, "extents": [0.2, 0.1, 0.3], "times_s": {}}
    return Reconstruction(textured=textured, views=[], frame=frame, figures=figures, work_dir=work_dir)


@pytest.mark.parametrize("scaled", [False, True])
def test_mass_is_null_for_an_unscaled_model_and_density_times_volume_for_a_metric_one(
    tmp_path: Path, scaled: bool
) -> None:
    out = tmp_path / "model"
    photos = tmp_path / "photos"
    photos.mkdir()
    options = ReconstructOptions(density_kg_m3=500.0)
    write_reconstruction(_reconstruction(scaled, tmp_path), out, options, photos_dir=photos)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["metric"] is scaled and summary["units"] == ("m" if scaled else "unscaled")
    if scaled:
        assert summary["mass_kg"] == pytest.approx(500.0 * 0.2 * 0.1 * 0.3, rel=1e-3)
        assert summary["extents_m"] == pytest.approx([0.2, 0.1, 0.3], abs=1e-6)
    else:
        assert summary["mass_kg"] is None and summary["extents_m"] is None
        assert summary["photogrammetry"]["extents_sfm_units"] == [0.2, 0.1, 0.3]
