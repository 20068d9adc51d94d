"""Shape completion end to end, through the command line: a small generated library, a model
trained on it (kept in the repository: tests/completion_model.py), unseen instances completed
from rendered depth images and scored against the truth with the shared metrics; training on a
tiny library through the command line."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh
import yaml
import completion_model
from completion_model import MODEL, TRAIN
from fixture_cache import cached_folder, content_key
from typer.testing import CliRunner

from homemodel.model_folder.gate.validate import validate_path
from homemodel.cli import app
from homemodel.core.errors import InputError
from homemodel.core.limits import MODEL_BYTES
from homemodel.core.safe_npz import read_npz, write_npz
from homemodel.core.transforms import world_from_camera_looking_at
from homemodel.evaluation import voxel_iou
from homemodel.geometry.mesh_io import load_mesh
from homemodel.evaluation.surface import distances_to_surface
from shape_completion.library import fingerprint_files, library_files
from shape_completion.model_io import load_model, save_model
from shape_completion.queries import FILLER_CAMERA, random_query_pose
from shape_completion.procedural import generate_instances
from homemodel.geometry.camera import Camera, save_camera
from homemodel.geometry.raycast import RayCaster
from homemodel.geometry.depth_io import write_depth

runner = CliRunner()
# The run tests check that the written mesh overlaps the truth (a wrong frame scores about 0) on
# 2 mm voxels: on this bottle and cup 0.834 and 0.544-0.548 IoU, against 0.830 and 0.461-0.464 on
# Rock et al.'s 200^3 grid over the pair, at 0.13 CPU-s a test instead of 0.6-2.0.
OVERLAP_VOXEL_M = 0.002


def invoke(*args: str):
    return runner.invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def trained() -> dict:
    """The library (regenerated once per content of the generator, and of the `completion library`
    command it runs with all it imports: tests/fixture_cache.py) and
    the model kept in the repository that was trained on it (tests/completion_model.py); tests
    only read them. Training itself is tested on a tiny library below."""
    settings = repr(completion_model.LIBRARY_OPTIONS)
    key = content_key(inputs=[Path(completion_model.__file__)], packages=("homemodel.cli",), settings=settings)
    root = cached_folder("completion_library", key, lambda folder: completion_model.write_library(folder / "library"))
    library_fingerprint = fingerprint_files(library_files(root / "library"))
    meta = json.loads(read_npz(MODEL, MODEL_BYTES)["meta"].tobytes())
    assert meta["library_fingerprint"] == library_fingerprint, (
        "the generator changed since tests/data/completion_model.npz was trained: run tests/completion_model.py"
    )
    return {"root": root, "library": root / "library", "model": MODEL}


@pytest.fixture(scope="module")
def completer(trained):
    return load_model(trained["model"])


@pytest.fixture(scope="module")
def scores(trained) -> dict[str, list[list[float]]]:
    """Per class, [IoU retrieval, IoU fitting, IoU filling, distance retrieval, distance filling]
    per unseen query (completion_model.write_unseen_scores), made once per content of the kept
    model, of the code that completes and scores, and of completion_model.py."""
    key = content_key(inputs=[MODEL, Path(completion_model.__file__)], packages=("shape_completion",))
    folder = cached_folder("completion_scores", key, completion_model.write_unseen_scores)
    return json.loads((folder / completion_model.SCORES).read_text())


@pytest.mark.slow
def test_completion_beats_retrieval_on_unseen_instances(scores):
    all_rows = np.array([row for rows in scores.values() for row in rows])
    iou_retrieval, iou_fitting, iou_filling, distance_retrieval, distance_filling = all_rows.mean(axis=0)
    assert iou_fitting > iou_retrieval + 0.05
    assert iou_filling > iou_retrieval + 0.05
    assert distance_filling < distance_retrieval
    assert iou_filling > 0.45  # on a library of 6 meshes per class and 20 views each
    for class_name, rows in scores.items():
        assert np.mean(rows, axis=0)[2] > 0.3, class_name


@pytest.mark.slow
def test_run_writes_a_valid_model_folder_in_the_camera_frame(trained, tmp_path):
    mesh = generate_instances("bottle", TRAIN + 1, seed=0)[TRAIN]
    camera_from_object = random_query_pose(mesh, np.random.default_rng(4))
    save_camera(FILLER_CAMERA.model_copy(update={"depth_scale_m": 0.0002}), tmp_path / "camera.yaml")
    write_depth(tmp_path / "depth.png", RayCaster(mesh).depth(FILLER_CAMERA, camera_from_object), depth_scale_m=0.0002)
    # As a user runs it, in a fresh process: a query loads only what it needs (no scikit-learn,
    # whose trees are numpy tables in the model file; no Open3D, whose import alone costs 0.3-0.7
    # CPU-s: the scan meshes measure a completion by numpy; no other part's commands).
    heavy = ("sklearn", "open3d", "homemodel.cli.turntable_commands", "homemodel.cli.photogrammetry_commands")
    code = (
        f"import atexit, sys; atexit.register(lambda: print('imported', [m for m in {heavy!r} if m in sys.modules],"
        " file=sys.stderr)); from homemodel.cli.launcher import main; main()"
    )
    run = subprocess.run(
        [sys.executable, "-c", code, "completion", "run", trained["model"], tmp_path / "depth.png", "--camera",
         tmp_path / "camera.yaml", "--out", tmp_path / "out", "--library", trained["library"]],
        capture_output=True, text=True, timeout=900,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    assert "imported []" in run.stderr, run.stderr
    assert validate_path(tmp_path / "out").ok
    written = json.loads((tmp_path / "out" / "summary.json").read_text())
    summary = written["completion"]
    assert summary["class"] == "bottle" and written["kind"] == "bottle" and written["times_s"]["filling"] > 0
    # The generator revolves a bottle about its z axis: the axis fitted to the query is that one.
    axis = summary["revolution_axis"]
    direction, point = np.array(axis["direction"]), np.array(axis["point_m"])
    true_direction, on_true_axis = camera_from_object[:3, 2], camera_from_object[:3, 3]
    assert abs(direction @ true_direction) > np.cos(np.radians(3))
    offset = point - on_true_axis
    assert np.linalg.norm(offset - (offset @ true_direction) * true_direction) < 0.003
    truth = mesh.copy().apply_transform(camera_from_object)
    completed = load_mesh(tmp_path / "out")
    # In the camera's frame: the surface the camera saw lies on the completed mesh (a wrong
    # frame is off by the camera distance, 0.35-0.7 m), and the whole overlaps the truth (a
    # wrong frame scores about 0; one query of a 6-mesh class scores 0.4-0.8 as instances vary).
    seen = FILLER_CAMERA.depth_to_points(RayCaster(mesh).depth(FILLER_CAMERA, camera_from_object))
    assert np.median(distances_to_surface(seen, completed)) < 0.003
    assert voxel_iou(completed, truth, voxel_size_m=OVERLAP_VOXEL_M) > 0.3


@pytest.mark.slow
@pytest.mark.parametrize("posed", [True, False], ids=["camera pose", "support plane"])
def test_run_writes_the_cup_upright_on_its_table(trained, tmp_path, posed: bool):
    """A robot's view of an unseen cup on a table (the table in the depth image, no mask): the
    model folder holds the cup standing on z = 0, z up, as high as the true cup."""
    cup = generate_instances("cup", TRAIN + 2, seed=0)[TRAIN + 1]
    table = trimesh.creation.box(extents=(1.2, 1.2, 0.03)).apply_translation((0.1, 0.2, -0.015))
    world_from_camera = world_from_camera_looking_at((0.4, -0.3, 0.35), (0.0, 0.0, 0.04))
    camera_from_world = np.linalg.inv(world_from_camera)
    depth = RayCaster(trimesh.util.concatenate([cup, table])).depth(FILLER_CAMERA, camera_from_world)
    write_depth(tmp_path / "depth.png", depth, depth_scale_m=FILLER_CAMERA.depth_scale_m)
    camera = FILLER_CAMERA.model_dump(exclude_none=True) | ({"map_from_camera": world_from_camera.tolist()} if posed else {})
    (tmp_path / "camera.yaml").write_text(yaml.safe_dump(camera))
    result = invoke("completion", "run", trained["model"], tmp_path / "depth.png", "--out", tmp_path / "out",
                    "--camera", tmp_path / "camera.yaml")  # fmt: skip
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())["completion"]
    assert summary["up_from"] == ("camera pose" if posed else "support plane")
    assert summary["frame"].startswith("object: +z up")
    camera_from_object = np.array(summary["camera_from_object"])
    completed = load_mesh(tmp_path / "out")
    truth = cup.copy().apply_transform(np.linalg.inv(camera_from_object) @ camera_from_world)
    # Up is the table's normal, the origin on the table: the truth stands on z = 0 in this frame.
    assert abs(truth.bounds[0, 2]) < 0.002 and abs(truth.extents[2] - cup.extents[2]) < 0.001
    assert abs(completed.bounds[0, 2]) < 0.005
    assert abs(completed.extents[2] / cup.extents[2] - 1) < 0.2
    assert voxel_iou(completed, truth, voxel_size_m=OVERLAP_VOXEL_M) > 0.3
    if posed:  # the map's axes, so the model drops into the map by a translation
        np.testing.assert_allclose(np.array(summary["map_from_object"])[:3, :3], np.eye(3), atol=1e-6)


@pytest.mark.slow
def test_bad_inputs_are_one_line_errors_and_write_nothing(trained, tmp_path):
    camera = Camera(width=64, height=48, fx=60.0, fy=60.0, cx=31.5, cy=23.5, depth_scale_m=0.001)
    save_camera(camera, tmp_path / "camera.yaml")
    empty = np.full((48, 64), np.nan)
    write_depth(tmp_path / "empty.png", empty, depth_scale_m=0.001)
    write_depth(tmp_path / "wrong_size.png", np.full((40, 64), 0.5), depth_scale_m=0.001)
    blob = empty.copy()
    blob[10:30, 20:40] = 0.5
    write_depth(tmp_path / "blob.png", blob, depth_scale_m=0.001)
    save_camera(camera.model_copy(update={"depth_scale_m": 1.0}), tmp_path / "metres_camera.yaml")
    write_depth(tmp_path / "in_mm.png", blob * 1000, depth_scale_m=1.0)  # 500 "metres" away
    (tmp_path / "corrupt.png").write_bytes(b"\x89PNG not really")
    cases = [
        ("empty.png", "camera.yaml", "no valid depth"),
        ("wrong_size.png", "camera.yaml", "64x40 px but"),
        ("in_mm.png", "metres_camera.yaml", "does not match the camera"),
        ("corrupt.png", "camera.yaml", "not a readable image"),
        ("missing.png", "camera.yaml", "no such file"),
    ]
    for depth, camera_file, message in cases:
        result = invoke(
            "completion",
            "run",
            trained["model"],
            tmp_path / depth,
            "--camera",
            tmp_path / camera_file,
            "--out",
            tmp_path / "out",
        )
        assert result.exit_code == 2, (depth, result.output)
        assert message in result.output and depth in result.output, result.output
        assert len(result.output.strip().splitlines()) == 1
        assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_models_are_refused_for_another_library_or_format(trained, completer, tmp_path):
    other = tmp_path / "other_library"
    result = invoke("completion", "library", "--out", other, "--classes", "cup", "--per-class", 2, "--seed", 5)
    assert result.exit_code == 0, result.output
    result = invoke(
        "completion",
        "run",
        trained["model"],
        tmp_path / "d.png",
        "--camera",
        tmp_path / "c.yaml",
        "--out",
        tmp_path / "out",
        "--library",
        other,
    )
    assert result.exit_code == 2 and "another version of the library" in result.output
    assert "model.npz" in result.output
    arrays = read_npz(trained["model"], MODEL_BYTES)
    meta = json.loads(arrays["meta"].tobytes())
    arrays["meta"] = np.frombuffer(json.dumps(meta | {"format_version": 99}).encode(), dtype=np.uint8)
    write_npz(tmp_path / "future.npz", arrays)
    with pytest.raises(InputError, match="future.npz: model format version 99"):
        load_model(tmp_path / "future.npz")
    (tmp_path / "junk.npz").write_bytes(b"not a model")
    with pytest.raises(InputError, match="junk.npz: not an .npz array file"):
        load_model(tmp_path / "junk.npz")
    completer.set_params(n_views=21)  # options that do not match the fingerprint
    try:
        save_model(completer, tmp_path / "tampered.npz")
    finally:
        completer.set_params(n_views=20)
    with pytest.raises(InputError, match="fingerprint does not match"):
        load_model(tmp_path / "tampered.npz")


def test_train_writes_a_model_that_knows_its_library_and_completes(tmp_path):
    """The training command on the least library and options it takes (plumbing, not accuracy:
    the model above is trained the same way on more)."""
    library = tmp_path / "library"
    assert invoke("completion", "library", "--out", library, "--classes", "cup", "--per-class", 2).exit_code == 0
    result = invoke("completion", "train", library, "--out", tmp_path / "model.npz", "--views", 4, "--filler-queries", 1)
    assert result.exit_code == 0, result.output
    completer = load_model(tmp_path / "model.npz", library_fingerprint=fingerprint_files(library_files(library)))
    assert completer.class_names_ == ["cup"] and len(completer.view_shape_) == 2 * 4
    mesh = generate_instances("cup", 3, seed=0)[2]
    depth = RayCaster(mesh).depth(FILLER_CAMERA, random_query_pose(mesh, np.random.default_rng(1)))
    completion = completer.complete(depth, FILLER_CAMERA)
    assert completion.class_name == "cup" and completion.mesh.is_watertight


def test_library_errors_name_the_folder(tmp_path):
    (tmp_path / "lib" / "cup").mkdir(parents=True)
    result = invoke("completion", "train", tmp_path / "lib", "--out", tmp_path / "m.npz")
    assert result.exit_code == 2 and "cup: an empty class: no mesh files" in result.output
    mesh = generate_instances("cup", 1)[0]
    mesh.apply_scale(1000.0)  # millimetres
    mesh.export(tmp_path / "lib" / "cup" / "a.ply")
    mesh.export(tmp_path / "lib" / "cup" / "b.ply")
    result = invoke("completion", "train", tmp_path / "lib", "--out", tmp_path / "m.npz")
    assert result.exit_code == 2 and "a.ply" in result.output and "in metres" in result.output


@pytest.mark.slow
def test_benchmark_writes_the_table_and_the_figure(tmp_path):
    library = tmp_path / "library"
    assert invoke("completion", "library", "--out", library, "--classes", "bottle", "--per-class", 4).exit_code == 0
    result = invoke(
        "completion",
        "benchmark",
        library,
        "--out",
        tmp_path / "bench",
        "--train",
        3,
        "--test",
        1,
        "--views",
        4,
        "--queries",
        1,
        "--filler-queries",
        1,
    )
    assert result.exit_code == 0, result.output
    results = json.loads((tmp_path / "bench" / "results.json").read_text())
    assert set(results["classes"]) == {"bottle"}
    row, (query,) = results["classes"]["bottle"], results["queries"]
    # The table's row is its one query's scores; even trained this little (the least training
    # the options allow, so the test stays quick), filling completes the unseen bottle better
    # than the retrieved one does (0.76 against 0.43 IoU here).
    for stage in ("retrieval", "fitting", "filling", "oracle"):
        assert row[f"iou_{stage}"] == pytest.approx(query["voxel_iou"][stage])
        assert row[f"distance_{stage}"] == pytest.approx(query["surface_distance"][stage])
    assert row["iou_filling"] > row["iou_retrieval"] + 0.05
    assert row["distance_filling"] < row["distance_retrieval"]
    assert row["iou_oracle"] > 0.4  # bottles of one generator resemble each other
    assert "| bottle |" in (tmp_path / "bench" / "table.md").read_text()
    assert (tmp_path / "bench" / "examples.png").read_bytes().startswith(b"\x89PNG")
    result = invoke("completion", "benchmark", library, "--out", tmp_path / "b2", "--train", 4, "--test", 1)
    assert result.exit_code == 2 and "needs 5" in result.output
