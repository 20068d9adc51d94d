"""Every options class checks itself (an InputError naming the field), and every pipeline's
entry function checks its options before it reads an input or writes an output."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

import modeller
import photogrammetry
import shape_completion
import tracking
import turntable
from homemodel.core.errors import InputError
from modeller.build import BuildOptions
from modeller.comparison_picture import PictureOptions
from modeller.photo_texture import FaceTextureOptions
from photogrammetry.cleaning import CleaningOptions
from photogrammetry.pipeline import ReconstructOptions
from photogrammetry.sfm import SfmOptions
from photogrammetry.stereo import DenseOptions
from photogrammetry.synthetic_scene import SceneOptions
from photogrammetry.texturing import TextureBakingOptions
from shape_completion.benchmark import BenchmarkOptions
from shape_completion.model_export import CompletionOptions
from tracking.observe import ObserveOptions
from tracking.simulate_view import ViewOptions
from turntable.capture_live import LiveCaptureOptions
from turntable.meshing import MeshingOptions
from turntable.pose import PoseOptions
from turntable.recordings.importer import ImportOptions
from turntable.simulate import SimulationOptions
from turntable.tags import DetectionOptions

# (options with one impossible field, the field the message must name)
BAD_OPTIONS = [
    (BuildOptions(name=""), "name"),
    (BuildOptions(texture=FaceTextureOptions(max_px_per_m=-1.0)), "texture.max_px_per_m"),
    (PictureOptions(panel_height_px=10), "panel_height_px"),
    (FaceTextureOptions(min_side_px=0), "min_side_px"),
    (CleaningOptions(min_piece_share=1.5), "min_piece_share"),
    (SfmOptions(matching="vocabulary"), "matching"),
    (DenseOptions(neighbours=0), "neighbours"),
    (SceneOptions(n_views=1), "n_views"),
    (TextureBakingOptions(min_cos=2.0), "min_cos"),
    (ReconstructOptions(texture=TextureBakingOptions(size_px=8)), "texture.size_px"),
    (ReconstructOptions(sfm=SfmOptions(max_num_features=10)), "sfm.max_num_features"),
    (BenchmarkOptions(train_per_class=1), "train_per_class"),
    (CompletionOptions(density_kg_m3=0.0), "density_kg_m3"),
    (MeshingOptions(normal_neighbours=1), "normal_neighbours"),
    (PoseOptions(min_tags=0), "min_tags"),
    (SimulationOptions(frames=0), "frames"),
    (DetectionOptions(decimate=-2.0), "decimate"),
    (turntable.ReconstructOptions(voxel_size_m=0.0), "voxel_size_m"),
    (turntable.ReconstructOptions(pose=PoseOptions(ransac_threshold_px=float("nan"))), "pose.ransac_threshold_px"),
    (LiveCaptureOptions(sectors=1), "sectors"),
    (ImportOptions(every=0), "every"),
    (ImportOptions(start_s=2.0, end_s=1.0), "end_s"),
    (ObserveOptions(rounds=0), "rounds"),
    (ViewOptions(occlude={"fridge": 2.0}), "occlude.fridge"),
]


@pytest.mark.parametrize(("options", "field"), BAD_OPTIONS, ids=lambda v: v if isinstance(v, str) else type(v).__name__)
def test_an_impossible_field_is_refused_by_name(options: object, field: str) -> None:
    with pytest.raises(InputError, match=rf"^{field}: "):
        options.check()


@pytest.mark.parametrize("options", sorted({type(o) for o, _ in BAD_OPTIONS}, key=lambda t: t.__name__))
def test_the_defaults_pass(options: type) -> None:
    options().check()


def test_every_options_class_is_covered() -> None:
    classes = {type(o) for o, _ in BAD_OPTIONS}
    for package in (modeller, turntable, photogrammetry, shape_completion, tracking):
        root = Path(package.__file__).parent
        for path in root.rglob("*.py"):
            for line in path.read_text().splitlines():
                if line.startswith("class ") and line.split("(")[0].split(":")[0].endswith("Options"):
                    name = line.split()[1].split("(")[0].split(":")[0]
                    assert name in {c.__name__ for c in classes}, f"{path}: {name} has no case here"


ENTRIES = [
    (lambda out: turntable.reconstruct(Path("no_capture"), out, replace(turntable.ReconstructOptions(), voxel_size_m=-1.0)), "voxel_size_m"),
    (lambda out: photogrammetry.reconstruct(Path("no_photos"), out, ReconstructOptions(dense=DenseOptions(neighbours=0))), "dense.neighbours"),
    (lambda out: shape_completion.complete(Path("no.model"), Path("no.png"), out, CompletionOptions(density_kg_m3=-1.0)), "density_kg_m3"),
    (lambda out: modeller.build(Path("no.yaml"), out, BuildOptions(name="")), "name"),
]


@pytest.mark.parametrize(("entry", "field"), ENTRIES, ids=["turntable", "photogrammetry", "completion", "modeller"])
def test_entry_functions_check_their_options_before_any_work(tmp_path: Path, entry, field: str) -> None:
    out = tmp_path / "out"
    # The inputs do not exist either: the options are refused first, and nothing is written.
    with pytest.raises(InputError, match=rf"^{field}: "):
        entry(out)
    assert not out.exists()
