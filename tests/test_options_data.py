"""The generic options <-> plain data converter: nested fields set one by one, every value
checked against its type with its path in the message, and every options class round-trips."""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import pytest
import yaml
from pydantic import BaseModel

from homemodel.core.errors import InputError
from homemodel.core.options_data import options_from_dict, options_to_dict
from photogrammetry.pipeline import ReconstructOptions
from photogrammetry.sfm import SfmOptions


@dataclass(kw_only=True)
class _Inner:
    size_px: int = 256
    scale: float = 1.0


@dataclass(kw_only=True)
class _Outer:
    inner: _Inner = field(default_factory=lambda: _Inner(size_px=512))  # not the class's own default
    maybe: _Inner | None = None
    mode: Literal["fast", "slow"] = "fast"
    path: Path | None = None
    sizes: tuple[float, float] = (1.0, 2.0)
    flag: bool = False


class _Pydantic(BaseModel):
    count: int = 3
    inner: _Inner = _Inner()


# Every options class of the project (issue 28 wants each to round-trip through plain data).
OPTIONS_CLASSES = """modeller.build.BuildOptions modeller.comparison_picture.PictureOptions
modeller.photo_texture.FaceTextureOptions photogrammetry.cleaning.CleaningOptions photogrammetry.sfm.SfmOptions
photogrammetry.stereo.DenseOptions photogrammetry.synthetic_scene.SceneOptions photogrammetry.texturing.TextureBakingOptions
photogrammetry.pipeline.ReconstructOptions shape_completion.benchmark.BenchmarkOptions
shape_completion.model_export.CompletionOptions turntable.meshing.MeshingOptions turntable.pose.PoseOptions
turntable.simulate.SimulationOptions turntable.tags.DetectionOptions turntable.reconstruction.ReconstructOptions
homemodel.model_folder.repair.RepairOptions homemodel.model_folder.asset_import.ImportOptions homemodel.app.database.build.DatabaseBuildOptions""".split()


@pytest.mark.parametrize("name", OPTIONS_CLASSES, ids=lambda n: n.rsplit(".", 1)[1])
def test_every_options_class_round_trips(name: str) -> None:
    module, cls = name.rsplit(".", 1)
    options_class = getattr(importlib.import_module(module), cls)
    options = options_class()
    data = options_to_dict(options)
    assert yaml.safe_load(yaml.safe_dump(data)) == data  # plain data: YAML holds it as it is
    assert options_from_dict(options_class, data) == options


@pytest.mark.parametrize("options", [_Outer(), _Pydantic(), _Outer(maybe=_Inner(scale=2.0), path=Path("x"))], ids=repr)
def test_nested_and_pydantic_options_round_trip(options: object) -> None:
    assert options_from_dict(type(options), options_to_dict(options)) == options


def test_a_nested_field_is_set_alone_over_the_outer_default() -> None:
    built = options_from_dict(ReconstructOptions, {"sfm": {"max_num_features": 8192}, "marker_size_m": 0.05})
    assert built.sfm.max_num_features == 8192
    assert built.sfm.max_image_size_px == SfmOptions().max_image_size_px  # the others stay
    assert built.marker_size_m == 0.05 and built.dense == ReconstructOptions().dense
    outer = options_from_dict(_Outer, {"inner": {"scale": 2}, "maybe": {"scale": 3}})
    assert outer.inner == _Inner(size_px=512, scale=2.0)  # 512: the outer class's default kept
    assert outer.maybe == _Inner(scale=3.0)
    assert options_from_dict(_Outer, {"maybe": None}).maybe is None


def test_values_are_converted_by_their_types() -> None:
    outer = options_from_dict(_Outer, {"path": "a/b.yaml", "sizes": [3, 4], "mode": "slow", "flag": True})
    assert outer.path == Path("a/b.yaml") and outer.sizes == (3.0, 4.0) and outer.mode == "slow" and outer.flag
    assert options_from_dict(_Pydantic, {"count": 7.0, "inner": {"size_px": 1}}) == _Pydantic(count=7, inner=_Inner(size_px=1))


@pytest.mark.parametrize(
    ("cls", "data", "message"),
    [
        (ReconstructOptions, {"sfm": {"max_num_features": "many"}}, r"^entries\.3\.options\.sfm\.max_num_features: expected a whole number"),
        (ReconstructOptions, {"sfm": {"max_features": 1}}, r"^entries\.3\.options\.sfm\.max_features: not a field of SfmOptions"),
        (ReconstructOptions, {"sfm": 5}, r"^entries\.3\.options\.sfm: expected a mapping of SfmOptions"),
        (ReconstructOptions, {"marker_size_m": float("nan")}, r"^entries\.3\.options\.marker_size_m: expected a finite number"),
        (ReconstructOptions, {"use_cuda": "yes"}, r"^entries\.3\.options\.use_cuda: expected true or false"),
        (ReconstructOptions, {"sfm": {"matching": "vocab"}}, r"^entries\.3\.options\.sfm\.matching: 'vocab' is not one of"),
        (_Outer, {"sizes": [1.0]}, r"^entries\.3\.options\.sizes: expected 2 values, got 1"),
        (_Outer, {"inner": {"size_px": 1.5}}, r"^entries\.3\.options\.inner\.size_px: expected a whole number"),
        (_Pydantic, {"count": True}, r"^entries\.3\.options\.count: expected a whole number"),
    ],
)
def test_a_bad_value_is_refused_with_its_path(cls: type, data: dict, message: str) -> None:
    with pytest.raises(InputError, match=message):
        options_from_dict(cls, data, where="entries.3.options")


def test_a_field_with_no_plain_form_is_refused_not_guessed() -> None:
    with pytest.raises(InputError, match=r"^options\.map_entry\.parent_from_object: .*cannot be set from plain data"):
        options_from_dict(ReconstructOptions, {"map_entry": {"map_path": "m.xml", "object_id": "a", "parent_id": "k", "parent_from_object": [1]}})
