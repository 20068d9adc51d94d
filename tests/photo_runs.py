"""The real photo sets reconstructed once for every test that reads them: a run through the
command line (`homemodel photogrammetry reconstruct`) kept with what the pipeline held in
memory on the way, made once per content of the photos, the settings and the code
(fixture_cache), so the pipeline, registration and support tests share one run per set
instead of reconstructing the same photos three times.

A folder holds `model/` (the command's model folder), and from the same run `mesh.ply` (the
final mesh, model frame), `scene_points.npy` (the fused dense points the cleaning started
from, support surface included, model frame), `model_from_sfm.npy` (the model frame in SfM's)
and `figures.json` (the pipeline's figures); the Buddha side run also `uncut/` (the same photos
without the support cut).
Treat it as read-only: `model_copy` gives a test its own copy.
"""

from __future__ import annotations

import copy
import dataclasses
import inspect
import json
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from fixture_cache import cached_folder, content_key

# What `homemodel photogrammetry reconstruct` runs, and no more: the photogrammetry package and
# the layers below it (fixture_cache.code_of), and the command line's own files (as a package,
# homemodel.cli would bring in every layer: the other pipelines and the app, which the command
# does not run). A change to any of it reconstructs again.
PIPELINE_CODE = ("photogrammetry",)
CLI_CODE = Path(__file__).resolve().parents[1] / "homemodel" / "cli"


class Kept:
    """One call of a pipeline stage kept in memory, handed to a later run of the same photos
    that calls the stage with equal arguments (all but the work folder, the progress callback
    and the thread count) instead of computing it again: SfM and the depth maps are the same
    for the runs with and without the support cut, and with one SfM both share one frame
    (two SfM runs repeat themselves only to the bit: test_structure_from_motion_repeats_itself).
    A call with other arguments is refused."""

    IGNORED = ("work_dir", "progress", "workers")

    def __init__(self, stage: Callable) -> None:
        self.stage = stage
        self.call: tuple[dict, object] | None = None
        self.handed = 0

    def _arguments(self, args: tuple, kwargs: dict) -> dict:
        bound = inspect.signature(self.stage).bind(*args, **kwargs)
        return {name: value for name, value in bound.arguments.items() if name not in self.IGNORED}

    def keeping(self, *args, **kwargs):  # noqa: ANN202 (the stage's own result)
        result = self.stage(*args, **kwargs)
        self.call = (copy.deepcopy(self._arguments(args, kwargs)), copy.deepcopy(result))
        return result

    def again(self, *args, **kwargs):  # noqa: ANN202
        kept_arguments, result = self.call
        arguments = self._arguments(args, kwargs)
        assert _same(arguments, kept_arguments), f"{self.stage.__name__}: not the kept call's arguments"
        self.handed += 1
        return copy.deepcopy(result)


def _same(a: object, b: object) -> bool:
    """Equal, looking into arrays, containers and dataclasses (a SparseModel, its Views)."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and np.array_equal(a, b)
    if type(a) is not type(b):
        return False
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list | tuple):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if dataclasses.is_dataclass(a):
        return _same(vars(a), vars(b))
    return a == b


def _command(folder: Path, photos: Path, args: list[str], kept: dict[str, Kept] | None = None) -> None:
    """`homemodel photogrammetry reconstruct PHOTOS --out folder/model ARGS` through the CLI, with
    what the pipeline held in memory on the way saved beside the model folder; `kept`: stages
    (by their name in photogrammetry.pipeline) of a run of the same photos, handed to the
    command's pipeline."""
    from typer.testing import CliRunner

    from homemodel.cli import app
    from photogrammetry import pipeline

    results = []
    run = pipeline.reconstruct_photos

    def keeping(*a, **kw):  # the CLI's own run, its in-memory result kept on the way
        results.append(run(*a, **kw))
        return results[-1]

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(pipeline, "reconstruct_photos", keeping)
        for name, stage in (kept or {}).items():
            patch.setattr(pipeline, name, stage.again)
        command = ["photogrammetry", "reconstruct", str(photos), "--out", str(folder / "model"), *args]
        result = CliRunner().invoke(app, command, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    assert all(stage.handed == 1 for stage in (kept or {}).values()), "the command ran a kept stage itself"
    (result_in_memory,) = results
    result_in_memory.mesh.export(folder / "mesh.ply")
    np.save(folder / "scene_points.npy", result_in_memory.scene_points)
    np.save(folder / "model_from_sfm.npy", result_in_memory.frame.model_from_sfm)
    (folder / "figures.json").write_text(json.dumps(result_in_memory.figures, default=str))


def cli_run(name: str, photos: Path, args: list[str]) -> Path:
    """The folder of `homemodel photogrammetry reconstruct PHOTOS --out model ARGS`, made once."""
    key = content_key(inputs=[photos, Path(__file__), CLI_CODE], packages=PIPELINE_CODE,
                      settings=json.dumps([name, args]))
    return cached_folder(f"photo_run_{name}", key, lambda folder: _command(folder, photos, args))


def rendered_run(scene) -> Path:  # noqa: ANN001 (photogrammetry.synthetic_scene.SyntheticScene)
    """The rendered set (tests/rendered_photo_set.py) through the command with its markers,
    registered on the table of a map made beside it (`map.xml`; the model folder `model/`),
    made once per content of the photos, the truth, the settings and the code."""
    args = ["--marker-size-m", str(scene.marker_size_m), "--dictionary", scene.dictionary, *RENDERED_ARGS]

    def make(folder: Path) -> None:
        from sample_house import build_house

        from homemodel.exchange.map_xml import save_map

        save_map(build_house(), folder / "map.xml")
        _command(folder, scene.folder / "images", [*args, "--map", str(folder / "map.xml")])

    key = content_key(inputs=[scene.folder, Path(__file__), CLI_CODE, Path(__file__).parent / "sample_house.py"],
                      packages=PIPELINE_CODE, settings=json.dumps(args))  # fmt: skip
    return cached_folder("photo_run_rendered", key, make)


def rendered_copy(run: Path, into: Path) -> tuple[Path, Path]:
    """The rendered run's model folder and map copied under `into` (the map's reference to the
    model is relative, so it holds in the copy): (model folder, map)."""
    shutil.copy(run / "map.xml", into / "map.xml")
    return model_copy(run, into), into / "map.xml"


def model_copy(run: Path, into: Path) -> Path:
    """The run's model folder copied under `into` (a test's tmp folder: the summary-schema check
    of conftest.py reads model folders made there)."""
    return Path(shutil.copytree(run / "model", into / "model"))


# The default command on Kermit's 11 photos (640 x 480), with a smaller texture and the cameras' picture.
KERMIT_ARGS = ["--texture-size-px", "1024", "--picture"]
# The rendered set (test_photogrammetry_pipeline's figures are from these): 1024 features
# a photo, SIFT on the 640 px photos as they are, depth maps at 480 px, a 1024 px texture, the
# model registered on the map's table.
RENDERED_ARGS = ["--max-features", "1024", "--first-octave", "0", "--depth-image-px", "480", "--texture-size-px", "1024",
                 "--name", "vase", "--parent", "table", "--xyz", "0.2", "0.1", "0.75"]  # fmt: skip
# 14 neighbouring photos of the Buddha set (the 13 nearest to 00040.jpg by the reference
# camera centres: about a quarter of the way round, at several heights), in no order.
BUDDHA_SIDE = ["00008.jpg", "00010.jpg", "00012.jpg", "00016.jpg", "00017.jpg", "00018.jpg", "00024.jpg",
               "00026.jpg", "00034.jpg", "00035.jpg", "00040.jpg", "00043.jpg", "00056.jpg", "00067.jpg"]  # fmt: skip
# SfM with the defaults (what the registration test is about); depth maps at 640 px, not the
# 1,223 px the 1600 px photos give (the cut and the registration are what is tested there;
# at 1,223 px the run took 18 minutes of busy cores), a 1024 px texture.
BUDDHA_SIDE_DEPTH_PX = 640
BUDDHA_SIDE_ARGS = ["--depth-image-px", str(BUDDHA_SIDE_DEPTH_PX), "--texture-size-px", "1024"]


def kermit_run(data: Path) -> Path:
    return cli_run("kermit", data / "kermit", KERMIT_ARGS)


def _buddha_side_photos(data: Path, scratch: Path) -> Path:
    """The 14 side photos linked into `scratch/photos` (a key reads their bytes, not the folder's path)."""
    photos = scratch / "photos"
    photos.mkdir(exist_ok=True)
    for name in BUDDHA_SIDE:
        if not (photos / name).exists():
            (photos / name).symlink_to(data / "buddha" / "images" / name)
    return photos


def buddha_side_runs(data: Path, scratch: Path) -> Path:
    """The 14 side photos twice, made once: without the support cut in memory (`uncut/`:
    `object_points.npy` and `model_from_sfm.npy`, at the run's depth size, a 256 px texture),
    then through the command with the cut (the folder of `cli_run`), its SfM and depth maps
    handed over from the first (the same photos, the same default SfM options, the same depth
    options and size): one dense stage instead of two, the same files to the bit. Cold, one
    after the other at a load of 12-23: 33.7 -> 25.7 CPU-s (dense 10.4 -> 5.1); 85 as two runs
    each with its own SfM (load 23-28). One SfM also gives both one frame, which two SfM runs
    give only when they repeat themselves to the bit."""
    from photogrammetry import pipeline
    from photogrammetry.cleaning import CleaningOptions
    from photogrammetry.stereo import DenseOptions
    from photogrammetry.texturing import TextureBakingOptions

    photos = _buddha_side_photos(data, scratch)

    def make(folder: Path) -> None:
        options = pipeline.ReconstructOptions(
            cleaning=CleaningOptions(remove_support=False), texture=TextureBakingOptions(size_px=256),
            dense=DenseOptions(max_image_size_px=BUDDHA_SIDE_DEPTH_PX),
        )
        kept = {name: Kept(getattr(pipeline, name)) for name in ("run_sfm", "compute_depth_maps")}
        with pipeline.temporary_work_dir() as work:  # the kept views' undistorted photos
            with pytest.MonkeyPatch.context() as patch:
                for name, stage in kept.items():
                    patch.setattr(pipeline, name, stage.keeping)
                uncut = pipeline.reconstruct_photos(photos, options, work_dir=Path(work))
            (folder / "uncut").mkdir()
            np.save(folder / "uncut" / "object_points.npy", uncut.object_points)
            np.save(folder / "uncut" / "model_from_sfm.npy", uncut.frame.model_from_sfm)
            _command(folder, photos, BUDDHA_SIDE_ARGS, kept)

    key = content_key(inputs=[photos, Path(__file__), CLI_CODE], packages=PIPELINE_CODE,
                      settings=json.dumps(BUDDHA_SIDE_ARGS))
    return cached_folder("photo_run_buddha_side", key, make)
