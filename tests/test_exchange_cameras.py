"""The one per-view camera file (`homemodel.exchange.cameras`): written and read back exactly,
the older shapes still read, and every bad file refused with its name and the problem."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from homemodel.core.errors import InputError
from homemodel.exchange.cameras import CameraView, read_cameras, true_cameras_file, write_cameras
from homemodel.geometry.camera import Camera

EXAMPLE_TRUE_POSES = Path(__file__).resolve().parents[1] / "examples" / "database" / "inputs" / "capture" / "true_poses.json"
PINHOLE = Camera(width=640, height=480, fx=600.0, fy=601.0, cx=319.5, cy=239.5)
FISHEYE = Camera(width=800, height=600, fx=300.0, fy=300.0, cx=400.0, cy=300.0,
                 distortion=(0.1, -0.01, 0.001, 0.0), distortion_model="kannala_brandt")  # fmt: skip


def _pose(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    pose = np.eye(4)
    pose[:3, :3] = q * np.sign(np.linalg.det(q))
    pose[:3, 3] = rng.normal(size=3)
    return pose


def test_views_round_trip_with_each_camera_stored_once(tmp_path: Path) -> None:
    views = [
        CameraView(name=f"{k:06d}", camera=PINHOLE if k % 2 else FISHEYE, camera_from_frame=_pose(k),
                   figures={"tags": k + 3})  # fmt: skip
        for k in range(5)
    ]
    path = tmp_path / "cameras.json"
    write_cameras(path, reversed(views), frame="table", skipped={"000009": "pose: 2 tags seen, 3 needed"})
    document = json.loads(path.read_text())
    assert document["format"] == "homemodel-cameras" and document["version"] == 1
    assert len(document["cameras"]) == 2 and "camera_from_table" in document["views"][0]
    read = read_cameras(path)
    assert read.frame == "table" and read.skipped == {"000009": "pose: 2 tags seen, 3 needed"}
    assert [v.name for v in read.views] == [v.name for v in views]
    for got, want in zip(read.views, views):
        assert got.camera == want.camera and got.figures == {"tags": want.figures["tags"]}
        np.testing.assert_allclose(got.camera_from_frame, want.camera_from_frame, atol=1e-9)
    assert set(read.poses) == {v.name for v in views}


def test_the_old_turntable_poses_file_still_reads() -> None:
    """examples/database holds a capture simulated before cameras.json: its true_poses.json."""
    document = json.loads(EXAMPLE_TRUE_POSES.read_text())
    read = read_cameras(EXAMPLE_TRUE_POSES)
    assert read.frame == "table" and len(read.views) == len(document["frames"]) > 0
    assert all(v.camera is None for v in read.views)  # the old file held no intrinsics
    first = document["frames"][0]
    np.testing.assert_array_equal(read.poses[first["frame"]], np.array(first["camera_from_table"]))


def test_the_old_photogrammetry_list_still_reads(tmp_path: Path) -> None:
    path = tmp_path / "cameras.json"
    pose = _pose(1)
    path.write_text(json.dumps([{"name": "a.jpg", "intrinsics": PINHOLE.matrix.tolist(), "camera_from_model": pose.tolist(),
                                 "width_px": 640, "height_px": 480}]))  # fmt: skip
    read = read_cameras(path)
    assert read.frame == "model" and read.views[0].camera == PINHOLE
    np.testing.assert_array_equal(read.poses["a.jpg"], pose)


def _document() -> dict:
    return {
        "format": "homemodel-cameras", "version": 1, "frame": "model",
        "cameras": {"c": {"width": 4, "height": 3, "fx": 2.0, "fy": 2.0, "cx": 1.5, "cy": 1.0}},
        "views": [{"name": "v", "camera": "c", "camera_from_model": np.eye(4).tolist()}],
    }  # fmt: skip


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda d: d.update(version=2), "not a homemodel-cameras file of version 1"),
        (lambda d: d.update(frame="world"), "frame: 'world' but expected one of"),
        (lambda d: d["cameras"]["c"].update(fx=-1.0), "cameras.c: fx: Input should be greater than 0"),
        (lambda d: d["views"][0].update(camera="d"), "view v: camera 'd' is not one of cameras"),
        (lambda d: d["views"][0].update(camera_from_model=[[1, 2], [3, 4]]), "view v: camera_from_model is not a finite 4x4"),
        (lambda d: d["views"][0]["camera_from_model"][0].__setitem__(0, float("nan")), "is not a finite 4x4"),
        (lambda d: d["views"].append(dict(d["views"][0])), "a view name appears twice"),
        (lambda d: d["views"][0].pop("camera_from_model"), "not a cameras file: KeyError"),
    ],
)
def test_a_bad_file_is_refused_naming_it_and_the_problem(tmp_path: Path, change, message: str) -> None:  # noqa: ANN001
    document = _document()
    change(document)
    path = tmp_path / "cameras.json"
    path.write_text(json.dumps(document))
    with pytest.raises(InputError, match=f"^{path}: .*" + message.replace("(", r"\(").replace(".", r"\.")):
        read_cameras(path)


def test_a_good_document_reads(tmp_path: Path) -> None:
    path = tmp_path / "cameras.json"
    path.write_text(json.dumps(_document()))
    assert read_cameras(path).views[0].camera.fx == 2.0


def test_writing_refuses_an_unknown_frame_or_a_view_without_camera(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="frame='world'"):
        write_cameras(tmp_path / "c.json", [], frame="world")
    with pytest.raises(ValueError, match="view v: no camera"):
        write_cameras(tmp_path / "c.json", [CameraView(name="v", camera=None, camera_from_frame=np.eye(4))], frame="table")
    assert not (tmp_path / "c.json").exists()


def test_a_capture_simulated_before_true_cameras_json_still_gives_its_truth(tmp_path: Path) -> None:
    assert true_cameras_file(tmp_path) == tmp_path / "true_cameras.json"  # a new capture's, even before it is written
    shutil.copy(EXAMPLE_TRUE_POSES, tmp_path / "true_poses.json")
    assert true_cameras_file(tmp_path) == tmp_path / "true_poses.json"
    assert len(read_cameras(true_cameras_file(tmp_path)).views) == 12
    write_cameras(tmp_path / "true_cameras.json", [CameraView(name="a", camera=PINHOLE, camera_from_frame=np.eye(4))], frame="table")
    assert true_cameras_file(tmp_path) == tmp_path / "true_cameras.json"


def test_a_missing_file_is_named_once(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=f"^{tmp_path / 'cameras.json'}: no such file$"):
        read_cameras(tmp_path / "cameras.json")
