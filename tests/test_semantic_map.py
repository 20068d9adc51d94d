"""The hierarchical semantic map: Figure 47's house, the blue-cup walk, files, history."""

from __future__ import annotations

import os
from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np
import pytest
from sample_house import (
    BLUE_CUP_POSE,
    HOSTILE,
    T0,
    TABLE_POSE,
    box_model,
    build_house,
    cup_model,
    cupboard_model,
    fridge_model,
    parking,
)

from homemodel.core.errors import MapError, UnsafeXMLError
from homemodel.core.transforms import transform_from_xyz_rpy
from semantic_map import LargeArticulatedObject, LargeObject, PoseRecord, SemanticMap, SmallObject
from homemodel.exchange.map_xml import load_map, map_to_bytes, save_map


# The blue-cup walk (D3.1 section 6.2.2, Figures 47-53)


def test_blue_cup_walk(house: SemanticMap) -> None:
    matches = house.find(type="cup", properties={"colour": "blue"})
    assert [m.id for m in matches] == ["blue_cup"]
    assert house.path_to("blue_cup") == ["house", "kitchen", "table", "blue_cup"]
    parent = house.parent("blue_cup")
    assert parent is not None and parent.id == "table"
    positions = house.parking_positions(parent.id)
    assert [(p.name, p.default) for p in positions] == [("front", True), ("left", False), ("right", False)]
    np.testing.assert_allclose(
        np.asarray(positions[0].world_from_base), transform_from_xyz_rpy((2, 0, 0), (0, 0, np.pi / 2)), atol=1e-12
    )
    assert [m.id for m in house.find(type="cup")] == ["red_cup", "blue_cup"]
    assert house.find(type="cup", properties={"colour": "green"}) == []


def test_world_from_object_composes_parent_and_child(house: SemanticMap) -> None:
    np.testing.assert_allclose(house.world_from_object("blue_cup"), TABLE_POSE @ BLUE_CUP_POSE, atol=1e-12)
    np.testing.assert_allclose(house.world_from_object("table"), TABLE_POSE, atol=1e-12)
    # The table is turned by 90 degrees, so the cup's x offset in the table frame is a y offset in the map.
    np.testing.assert_allclose(house.world_from_object("blue_cup")[:3, 3], (2.1, 1.3, 0.75), atol=1e-12)


def test_queries_refuse_what_has_no_answer(house: SemanticMap) -> None:
    with pytest.raises(MapError, match="no node with id 'green_cup'"):
        house.node("green_cup")
    with pytest.raises(MapError, match="parking positions belong to its parent 'table'"):
        house.parking_positions("blue_cup")
    with pytest.raises(MapError, match="only objects and switches have a pose"):
        house.world_from_object("kitchen")
    assert house.parent("house") is None
    assert house.parent("kitchen_light").id == "kitchen"


# Registration: what flows from the model into the map


def test_articulated_model_becomes_large_articulated_object(house: SemanticMap) -> None:
    model = cupboard_model()
    cupboard = house.node("cupboard")
    assert isinstance(cupboard, LargeArticulatedObject)
    assert (cupboard.type, cupboard.affordances, cupboard.graspable) == ("cupboard", ["container"], False)
    assert cupboard.properties == {"colour": "white"}
    hinge, lock = cupboard.joints
    assert (hinge.name, hinge.type, hinge.limits, hinge.position, hinge.parent) == (
        "door_hinge",
        "revolute",
        (0.0, 1.9),
        0.0,
        None,
    )
    assert [(s.name, s.position) for s in hinge.states] == [("closed", 0.0), ("open", 1.57)]
    # The hinge axis is y in its rolled joint frame, z (vertical) in the object frame.
    np.testing.assert_allclose(hinge.axis, (0, 0, 1), atol=1e-12)
    np.testing.assert_allclose(hinge.object_from_joint.xyz, (0.3, -0.25, 0.05), atol=1e-12)
    assert (lock.type, lock.limits, lock.parent) == ("continuous", None, "door_hinge")
    handle, knob = cupboard.grasp_points
    assert (handle.kind, handle.joint, knob.kind, knob.joint) == ("handle", "door_hinge", "knob", "lock")
    expected = model.world_from_grasp_points()
    np.testing.assert_allclose(np.asarray(handle.object_from_grasp), expected["door_handle"], atol=1e-12)
    fridge = house.node("fridge")
    assert isinstance(fridge, LargeArticulatedObject) and fridge.joints[0].type == "prismatic"
    assert fridge.grasp_points[0].joint == "freezer_drawer"


def test_plain_and_small_objects(house: SemanticMap) -> None:
    table, cup = house.node("table"), house.node("blue_cup")
    assert type(table) is LargeObject and table.affordances == ["supporting_surface"] and not table.graspable
    assert isinstance(cup, SmallObject)
    assert (cup.type, cup.parent, cup.relation, cup.graspable) == ("cup", "table", "on", True)
    # Given properties win over the model's, the others stay.
    assert cup.properties == {"colour": "blue", "material": "ceramic"}
    assert [p.name for p in cup.default_positions] == ["registered"]
    assert cup.grasp_points[0].joint is None and cup.grasp_points[0].kind == "body"


def test_grasp_points_follow_joint_states(house: SemanticMap) -> None:
    model = cupboard_model()
    world_from_cupboard = house.world_from_object("cupboard")
    house.set_joint_state("cupboard", "door_hinge", 1.2, time=T0)
    house.set_joint_state("cupboard", "lock", -0.7, time=T0)
    posed = model.world_from_grasp_points({"door_hinge": 1.2, "lock": -0.7})
    for name in ("door_handle", "lock_knob"):
        np.testing.assert_allclose(
            house.world_from_grasp_point("cupboard", name), world_from_cupboard @ posed[name], atol=1e-12
        )
    house.set_joint_state("fridge", "freezer_drawer", 0.3, time=T0)
    drawer = fridge_model().world_from_grasp_points({"freezer_drawer": 0.3})["drawer_handle"]
    np.testing.assert_allclose(
        house.world_from_grasp_point("fridge", "drawer_handle"), house.world_from_object("fridge") @ drawer, atol=1e-12
    )


def test_registration_errors(house: SemanticMap) -> None:
    cup = cup_model()
    with pytest.raises(MapError, match="'red_cup' is already in the map"):
        house.register_model(cup, object_id="red_cup", parent_id="table")
    with pytest.raises(MapError, match="no node with id 'sofa'"):
        house.register_model(cup, object_id="cup_9", parent_id="sofa")
    with pytest.raises(MapError, match="cannot place 'cup_9' under 'red_cup', a SmallObject"):
        house.register_model(cup, object_id="cup_9", parent_id="red_cup")
    with pytest.raises(MapError, match="exactly one default parking position, got 0"):
        house.register_model(box_model("chair", (0.4, 0.4, 0.9)), object_id="chair", parent_id="kitchen")
    with pytest.raises(MapError, match="got 2"):
        house.register_model(
            box_model("chair", (0.4, 0.4, 0.9)),
            object_id="chair",
            parent_id="kitchen",
            parking_positions=[parking("a", 0, 0, 0, default=True), parking("b", 1, 0, 0, default=True)],
        )
    with pytest.raises(MapError, match="relation .* applies to small objects only"):
        house.register_model(box_model("chair", (0.4, 0.4, 0.9)), object_id="chair", parent_id="kitchen", relation="on")
    with pytest.raises(MapError, match="not a valid id"):
        house.register_model(cup, object_id="9 cups", parent_id="table")
    with pytest.raises(MapError, match="outside its limits"):
        house.register_model(
            cupboard_model(),
            object_id="cupboard_2",
            parent_id="kitchen",
            parking_positions=[parking("front", 0, 0, 0, default=True)],
            joint_positions={"door_hinge": 2.5},
        )
    # Nothing half-registered stays behind.
    assert [o.id for o in house.objects()] == ["table", "red_cup", "bowl", "sugar", "blue_cup", "cupboard", "fridge"]


# Files: round trip, determinism, schema, hostile XML, atomic writes


def test_round_trip_is_exact_and_deterministic(house: SemanticMap, house_file: Path) -> None:
    loaded = load_map(house_file)
    assert loaded == house
    assert map_to_bytes(loaded) == house_file.read_bytes() == map_to_bytes(build_house())
    assert loaded.path_to("blue_cup") == ["house", "kitchen", "table", "blue_cup"]
    np.testing.assert_array_equal(loaded.world_from_object("blue_cup"), house.world_from_object("blue_cup"))
    text = house_file.read_text()
    assert 'xmlns="https://homemodel.dev/semantic-map/1"' in text
    assert '<largeArticulatedObject id="cupboard"' in text and '<defaultParking name="front"' in text


def test_updates_survive_a_round_trip(house: SemanticMap, tmp_path: Path) -> None:
    house.update_pose("table", transform_from_xyz_rpy((2.5, 1.0, 0.0)), time=T0)
    house.set_joint_state("cupboard", "door_hinge", "open", time=T0 + timedelta(seconds=1))
    house.move_object(
        "bowl", parent_id="cupboard", relation="in", parent_from_object=transform_from_xyz_rpy((0, 0, 0.4)), time=T0
    )
    path = tmp_path / "map.xml"
    save_map(house, path)
    loaded = load_map(path)
    assert loaded == house
    assert loaded.path_to("bowl") == ["house", "kitchen", "cupboard", "bowl"]
    assert map_to_bytes(loaded) == path.read_bytes()


def _invalid(house_file: Path, old: str, new: str) -> Path:
    text = house_file.read_text()
    assert old in text
    house_file.write_text(text.replace(old, new, 1))
    return house_file


@pytest.mark.parametrize(
    ("old", "new", "problem"),
    [
        ('id="bowl"', 'id="red_cup"', "'red_cup' is not a valid value of the atomic type 'xs:ID'"),
        ('type="revolute"', 'type="screw"', "The value 'screw' is not an element of the set"),
        ('id="blue_cup" type="cup" parent="table"', 'id="blue_cup" type="cup" parent="fridge"', "['fridge'] of keyref"),
        ('relation="on"', 'relation="beside"', "'beside' is not an element of the set"),
    ],
    ids=["duplicate-id", "bad-joint-type", "parent-disagrees-with-nesting", "bad-relation"],
)
def test_schema_rejects(house_file: Path, old: str, new: str, problem: str) -> None:
    _invalid(house_file, old, new)
    with pytest.raises(MapError) as info:
        load_map(house_file)
    message = str(info.value)
    assert message.startswith(f"{house_file}: line ") and problem in message and "\n" not in message


def test_schema_requires_a_default_parking_position(house_file: Path) -> None:
    text = house_file.read_text()
    lines = [line for line in text.splitlines(keepends=True) if '<defaultParking name="front" xyz="2.0' not in line]
    assert len(lines) == len(text.splitlines()) - 1
    house_file.write_text("".join(lines))
    with pytest.raises(MapError, match=r"map\.xml: line \d+: .*Expected is \( defaultParking \)"):
        load_map(house_file)


def test_load_checks_joint_positions_against_limits(house_file: Path) -> None:
    _invalid(
        house_file,
        'name="door_hinge" type="revolute" position="0.0"',
        'name="door_hinge" type="revolute" position="2.5"',
    )
    with pytest.raises(MapError, match=r"map\.xml: line \d+: joint 'door_hinge': position 2.5 is outside its limits"):
        load_map(house_file)


def test_save_refuses_an_invalid_map_and_keeps_the_old_file(house: SemanticMap, house_file: Path) -> None:
    before = house_file.read_bytes()
    house.node("table").parking_positions.pop(0)  # a direct edit that loses the default parking position
    with pytest.raises(MapError, match=r"not saved: the map is invalid \(in 'table'\)"):
        save_map(house, house_file)
    assert house_file.read_bytes() == before
    assert os.listdir(house_file.parent) == ["map.xml"]


def test_a_map_needs_a_room(tmp_path: Path) -> None:
    with pytest.raises(MapError, match="not saved"):
        save_map(SemanticMap.new(apartment_id="house", name="House"), tmp_path / "map.xml")
    assert not (tmp_path / "map.xml").exists()


def test_atomic_save_survives_a_crash(house: SemanticMap, house_file: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    before = house_file.read_bytes()
    house.update_pose("blue_cup", transform_from_xyz_rpy((0, 0, 0.75)), time=T0)

    def crash(*_: object) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", crash)
    with pytest.raises(MapError, match="cannot write: No space left on device"):
        save_map(house, house_file)
    assert house_file.read_bytes() == before
    assert os.listdir(house_file.parent) == ["map.xml"]




@pytest.mark.parametrize("name", sorted(HOSTILE))
def test_hostile_xml_is_refused(tmp_path: Path, name: str) -> None:
    path = tmp_path / f"{name}.xml"
    path.write_bytes(HOSTILE[name])
    with pytest.raises(UnsafeXMLError) as info:
        load_map(path)
    assert str(info.value) == f"{path}: DOCTYPE or entity declarations are not allowed"


# History


def test_updates_keep_a_timestamped_history(house: SemanticMap, tmp_path: Path) -> None:
    cup = house.node("blue_cup")
    old_pose = cup.parent_from_object
    house.update_pose("blue_cup", transform_from_xyz_rpy((0.1, 0.1, 0.75)), time=T0)
    assert cup.history == [PoseRecord(until=T0, pose=old_pose, parent="table", relation="on")]
    np.testing.assert_allclose(
        house.world_from_object("blue_cup"), TABLE_POSE @ transform_from_xyz_rpy((0.1, 0.1, 0.75)), atol=1e-12
    )

    house.set_joint_state("cupboard", "door_hinge", "open", time=T0 + timedelta(minutes=1))
    house.set_joint_state("cupboard", "door_hinge", 0.25, time=T0 + timedelta(minutes=2))
    cupboard = house.node("cupboard")
    assert [(r.joint, r.position, r.until) for r in cupboard.history] == [
        ("door_hinge", 0.0, T0 + timedelta(minutes=1)),
        ("door_hinge", 1.57, T0 + timedelta(minutes=2)),
    ]
    assert cupboard.joint("door_hinge").position == 0.25

    house.update_pose("cupboard", transform_from_xyz_rpy((4.0, 0.5, 0.0)))  # now, in UTC
    assert len(cupboard.history) == 3 and cupboard.history[-1].until.tzinfo == timezone.utc
    path = tmp_path / "map.xml"
    save_map(house, path)
    text = path.read_text()
    assert '<jointState until="2025-03-01T09:31:00Z" joint="door_hinge" position="0.0"/>' in text
    assert (
        '<pose until="2025-03-01T09:30:00Z" parent="table" relation="on" xyz="0.3 -0.1 0.75" rpy="0.0 0.0 0.4"/>'
        in text
    )
    assert '<axis xyz="0.0 0.0 1.0"/>' in text  # float noise of the rolled joint frame rounded away


def test_history_refuses_bad_updates(house: SemanticMap) -> None:
    with pytest.raises(MapError, match=r"position 2.5 is outside its limits \[0.0, 1.9\]"):
        house.set_joint_state("cupboard", "door_hinge", 2.5, time=T0)
    with pytest.raises(MapError, match="has no state 'ajar'"):
        house.set_joint_state("cupboard", "door_hinge", "ajar", time=T0)
    with pytest.raises(MapError, match="has no joint 'lid'"):
        house.set_joint_state("cupboard", "lid", 0.1, time=T0)
    with pytest.raises(MapError, match="'table' is a LargeObject, which has no joints"):
        house.set_joint_state("table", "door_hinge", 0.1, time=T0)
    assert house.node("cupboard").history == []
    house.set_joint_state("cupboard", "door_hinge", 0.5, time=T0)
    with pytest.raises(MapError, match="before its last recorded change"):
        house.set_joint_state("cupboard", "door_hinge", 0.6, time=T0 - timedelta(seconds=1))
    with pytest.raises(ValueError, match="has no time zone"):
        house.update_pose("table", TABLE_POSE, time=datetime(2025, 3, 1, 9, 30))


def test_move_object_records_where_it_was(house: SemanticMap) -> None:
    house.move_object(
        "blue_cup", parent_id="cupboard", relation="in", parent_from_object=transform_from_xyz_rpy((0, 0, 0.5)), time=T0
    )
    cup = house.node("blue_cup")
    assert house.path_to("blue_cup") == ["house", "kitchen", "cupboard", "blue_cup"]
    assert (cup.parent, cup.relation) == ("cupboard", "in")
    assert [o.id for o in house.node("table").small_objects] == ["red_cup", "bowl", "sugar"]
    assert (cup.history[-1].parent, cup.history[-1].relation) == ("table", "on")


def test_small_object_with_joints(house: SemanticMap, tmp_path: Path) -> None:
    """A small object may be articulated (a pill box's lid): its joints, grasp points that
    follow them and its joint-state history reach the map and survive a save and load."""
    house.register_model(
        fridge_model(),
        object_id="toy_fridge",
        parent_id="table",
        parent_from_object=transform_from_xyz_rpy((0, 0, 0.75)),
    )
    toy = house.node("toy_fridge")
    assert isinstance(toy, SmallObject) and [j.name for j in toy.joints] == ["freezer_drawer"]
    closed = house.world_from_grasp_point("toy_fridge", "drawer_handle")
    house.set_joint_state("toy_fridge", "freezer_drawer", 0.25, time=datetime(2026, 1, 1, tzinfo=timezone.utc))
    opened = house.world_from_grasp_point("toy_fridge", "drawer_handle")
    # The drawer slides 0.25 m along the toy's +x, which the table's pose turns in the map frame.
    world_from_table = house.world_from_object("table")
    np.testing.assert_allclose(opened[:3, 3] - closed[:3, 3], world_from_table[:3, :3] @ [0.25, 0, 0], atol=1e-9)
    with pytest.raises(MapError, match="outside its limits"):
        house.set_joint_state("toy_fridge", "freezer_drawer", 0.5)
    path = tmp_path / "map.xml"
    save_map(house, path)
    loaded = load_map(path)
    reloaded = loaded.node("toy_fridge")
    assert isinstance(reloaded, SmallObject)
    assert reloaded.joint("freezer_drawer").position == pytest.approx(0.25)
    assert [r.joint for r in reloaded.history] == ["freezer_drawer"]
    np.testing.assert_allclose(loaded.world_from_grasp_point("toy_fridge", "drawer_handle"), opened, atol=1e-9)
