"""PartNet-Mobility import: category from meta.json, handles as grasp points, the frame turned
to face +x on the floor; repairs stated one by one; the repaired model passes the gate."""

from __future__ import annotations

import numpy as np
import pytest

from homemodel.exchange.model_files import write_model_files
from homemodel.model_folder.gate import validate_path
from homemodel.exchange.partnet import import_partnet
from homemodel.model_folder.repair import RepairOptions, find_gaps, repair
from homemodel.core.errors import InputError
from partnet_sample import HANDLE, HEIGHT_M, WIDTH_M, write_partnet_cabinet


@pytest.fixture(scope="module")
def cabinet(tmp_path_factory) -> object:
    return write_partnet_cabinet(tmp_path_factory.mktemp("partnet") / "cabinet")


def test_category_handle_and_frame(cabinet) -> None:
    imported = import_partnet(cabinet)
    model = imported.model
    assert model.category == "cupboard"
    assert model.properties["partnet_category"] == "StorageFurniture"
    assert imported.front_from == "handles"
    low, high = model.world_mesh().bounds
    # Standing on the floor, z up: the source's height (mesh y) is now along z.
    assert low[2] == pytest.approx(0.0, abs=1e-9)
    assert high[2] - low[2] == pytest.approx(HEIGHT_M, abs=1e-6)
    assert high[1] - low[1] == pytest.approx(WIDTH_M, abs=1e-6)
    # The handle: one grasp point at its centre, on the door's link, at the front (+x).
    [grasp] = model.grasp_points
    assert grasp.link == "link_0" and grasp.kind == "handle"
    world = model.world_from_grasp_points()[grasp.name]
    assert world[0, 3] == pytest.approx(high[0] - (HANDLE[1][0] - HANDLE[0][0]) / 2, abs=1e-6)
    assert world[2, 3] == pytest.approx(HEIGHT_M / 2, abs=1e-6)  # mesh y = 0 is half way up
    np.testing.assert_allclose(world[:3, 0], [1, 0, 0], atol=1e-9)  # grasp x out of the front


def test_the_door_opens_outwards_and_stays_on_its_hinge(cabinet) -> None:
    model = import_partnet(cabinet).model
    closed = model.world_from_grasp_points()["link_0_handle0"][:3, 3]
    opened = model.world_from_grasp_points({"joint_0": 1.2})["link_0_handle0"][:3, 3]
    assert opened[0] > closed[0] + 0.1  # swung out of the front
    assert opened[2] == pytest.approx(closed[2])  # about a vertical axis


def test_gaps_are_found_and_each_repair_is_stated_then_the_gate_passes(cabinet, tmp_path) -> None:
    gaps = find_gaps(cabinet / "mobility.urdf")
    assert gaps.links_without_inertial == ["link_1", "link_0"]
    assert gaps.limits_without_effort == ["joint_0"] and gaps.limits_without_velocity == ["joint_0"]
    assert not validate_path(cabinet / "mobility.urdf").ok  # as PartNet ships it
    model, done = repair(import_partnet(cabinet).model, gaps, RepairOptions(density_kg_m3=600.0, effort=5.0, velocity=0.5))
    assert len(done) == 3 and "600 kg/m^3" in done[0] and "effort set to 5, velocity set to 0.5" in done[2]
    body = next(link for link in model.links if link.name == "link_1")
    assert body.inertial.mass_kg == pytest.approx(600.0 * 0.4 * 0.8 * 0.6, rel=1e-6)
    write_model_files(model, tmp_path)
    report = validate_path(tmp_path)
    assert report.ok, report.format()


def test_a_bad_meta_json_is_an_input_error_naming_it(cabinet, tmp_path) -> None:
    broken = write_partnet_cabinet(tmp_path / "broken")
    (broken / "meta.json").write_text("{not json")
    with pytest.raises(InputError, match="meta.json"):
        import_partnet(broken)
