"""Random "real" pieces the builder never made (`unseen_pieces`), measured by the README's
guide alone and rebuilt; the hardest of `benchmarks/bench_modeller_unseen.py`'s sweep kept
here. Also the fields that sweep asked for: fronts over a face frame's overhang, a second
board's height, a button's body depth, the door's thickness from the square reading's two
faces; and a whole home's build showing its models' warnings.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from spec_edits import read_spec, with_field, write_spec
from test_modeller_real_features import MW_DOOR, _microwave_spec, _true_microwave_axis_m
from test_modeller_unseen_furniture import measure
from unseen_pieces import cabinet, microwave, oven

from homemodel.core.errors import SpecError
from modeller.spec_loading import load_spec
from modeller.specs.cabinet_geometry import door_hinge_point_m, hinge_tape_warnings

REPO = Path(__file__).resolve().parents[1]
CATALOGUE = REPO / "examples" / "catalogue"

# (maker, seed): pieces the sweep failed on before their fixes, and the builds the last round
# left untested: 23, a bank of three drawers with second boards under an open top's rails
# (the boards ran into the front rail); 36, a wall cabinet with two inset doors inside a face
# frame; 5, a tall unit with an inset door and two drawers between a frame's middle rails;
# 115, an oven whose knobs and button sit in pockets (a pocket reaching the carcass' edge is
# now refused); 18, a microwave whose 45-70 mm door is partly in its recess.
HARDEST = [(cabinet, 23), (cabinet, 36), (cabinet, 5), (oven, 115), (microwave, 18)]


@pytest.mark.bpy
@pytest.mark.parametrize(("maker", "seed"), HARDEST, ids=lambda v: getattr(v, "__name__", str(v)))
def test_random_real_pieces_rebuild_within_the_targets(tmp_path: Path, maker, seed: int) -> None:
    figures = measure(maker(seed), tmp_path)
    assert figures["gate_ok"], figures["gate"]
    assert max(figures["hinge_mm"].values(), default=0) < 5.0 and max(figures["hinge_deg"].values(), default=0) < 1.0
    assert max(figures["corners_mm"].values()) < 5.0, figures
    assert min(figures["iou_open"], figures["iou_closed"]) >= 0.85, figures


def test_the_square_readings_two_faces_give_the_thickness_the_line_is_solved_with(tmp_path: Path) -> None:
    """The microwave's 65 mm door given as 46 mm: with its outer face read too, the line is
    where it is and the build says the spec's thickness is not the door's."""
    data = _microwave_spec(MW_DOOR["thick"], 0.0, ("open_at_90",))
    square = data["doors"][0]["hinge_measured"]["open_at_90"]
    spec = load_spec(write_spec(tmp_path, data, "inner_only.yaml"))
    off_before = np.linalg.norm(door_hinge_point_m(spec, spec.doors[0])[:2] - _true_microwave_axis_m())
    square["outer_face_out_m"] = round(square["inner_face_out_m"] + MW_DOOR["thick"], 3)
    spec = load_spec(write_spec(tmp_path, data, "both_faces.yaml"))
    off = np.linalg.norm(door_hinge_point_m(spec, spec.doors[0])[:2] - _true_microwave_axis_m())
    assert off_before > 0.01 and off < 0.0015, (off_before, off)  # 13.4 mm, then 0.4 mm
    (warning,) = hinge_tape_warnings(spec)
    assert "is 65 mm thick" in warning and "the spec says 46 mm" in warning and warning.startswith("doors.0.")
    # Agreeing with the spec: no warning; an outer face nearer than the inner one is refused.
    data["doors"][0]["thickness_m"] = MW_DOOR["thick"]
    assert hinge_tape_warnings(load_spec(write_spec(tmp_path, data, "agree.yaml"))) == []
    square["outer_face_out_m"] = square["inner_face_out_m"] - 0.01
    with pytest.raises(SpecError, match=r"doors\.0\.hinge_measured\.open_at_90\.outer_face_out_m: .*larger reading"):
        load_spec(write_spec(tmp_path, data, "swapped.yaml"))


@pytest.mark.parametrize(
    ("example", "field", "value", "message"),
    [
        ("base_unit_frame_overlay", "doors.0.left_m", -0.01, r"doors\.0\.left_m: .*face frame 0\.008 m past each side"),
        ("base_unit_frame_overlay", "drawers.0.left_m", 0.004, r"drawers\.0\.left_m: drawer spans 0\.004\.\.0\.616"),
        ("base_unit_frame_overlay", "drawers.0.inner_board_height_m", 0.12, r"drawers\.0\.inner_board_height_m: .*above its opening's top at 0\.832"),
        ("base_unit_frame_overlay", "drawers.0.inner_board_m", 0.0, r"drawers\.0\.inner_board_height_m: .*needs its inner_board_m"),
        ("oven_pocketed_controls", "buttons.0.body_depth_m", 0.0101, r"buttons\.0\.body_depth_m: .*goes through its pocket's floor"),
        ("oven_pocketed_controls", "knobs.3.height_m", 0.57, r"knobs\.3\.pocket: the pocket round knob 3 reaches into the carcass' edge"),
        ("cupboard", "doors.0.left_m", -0.002, r"doors\.0\.left_m: door spans -0\.002"),
    ],
)
def test_the_new_fields_refuse_what_cannot_be(tmp_path: Path, example: str, field: str, value, message: str) -> None:
    spec_path = write_spec(tmp_path, with_field(read_spec(CATALOGUE / f"{example}.yaml"), field, value))
    with pytest.raises(SpecError, match=message):
        load_spec(spec_path)


def test_a_button_without_a_pocket_has_no_body_depth_of_its_own(tmp_path: Path) -> None:
    data = read_spec(CATALOGUE / "microwave_release_button.yaml")
    data["buttons"][0]["body_depth_m"] = 0.01
    with pytest.raises(SpecError, match=r"buttons\.0\.body_depth_m: .*give a pocket"):
        load_spec(write_spec(tmp_path, data))


@pytest.mark.bpy
def test_the_examples_build_fronts_over_the_overhang_a_low_second_board_and_a_shallow_button() -> None:
    from modeller import build_model

    unit = build_model(CATALOGUE / "base_unit_frame_overlay.yaml")
    world = unit.world_from_links()
    w = 0.6
    for link in ("door_0", "drawer_0"):
        points = np.concatenate([
            (world[link] @ v.link_from_visual @ np.c_[v.mesh.vertices, np.ones(len(v.mesh.vertices))].T).T[:, :3]
            for v in unit.link(link).visuals if not v.name.endswith("handle")
        ])
        assert points[:, 1].min() == pytest.approx(-w / 2 - 0.006, abs=1e-6), link  # over the 8 mm overhang
        assert points[:, 1].max() == pytest.approx(w / 2 + 0.006, abs=1e-6), link
    board = next(c for c in unit.link("drawer_0").collisions if c.name == "drawer_0_inner_board")
    centre_z = board.link_from_collision[2, 3]
    height = board.geometry.size_m[2]
    # The box 22 mm above the front's bottom edge; the board 85 mm high from there.
    assert centre_z - height / 2 == pytest.approx(0.022) and height == pytest.approx(0.085)
    # The door solved with the square reading's 19 mm (13 - -6): its line 10 mm behind its face, 3 mm in.
    hinge = unit.joint("door_0_hinge").parent_from_joint[:3, 3]
    assert hinge[0] == pytest.approx(0.28 + 0.002 + 0.019 - 0.010, abs=1e-6)
    assert hinge[1] == pytest.approx(-w / 2 - 0.006 + 0.003, abs=1e-6)
    oven_model = build_model(CATALOGUE / "oven_pocketed_controls.yaml")
    button = next(c for c in oven_model.link("button_0").collisions)
    size_x, centre_x = button.geometry.size_m[0], button.link_from_collision[0, 3]
    assert size_x == pytest.approx(0.007) and centre_x + size_x / 2 == pytest.approx(-0.001)  # 1 mm below the face
    assert all(oven_model.joint(f"knob_{k}_turn").type == "revolute" for k in range(4))
    assert math.isclose(oven_model.joint("button_0_press").limits.upper, 0.006)


@pytest.mark.bpy
def test_a_home_build_shows_each_models_warnings(tmp_path: Path) -> None:
    """`homemodel build` prints a model's warnings (here a door's readings against its
    thickness, and the gate's rub at its hinge line) under its table, and its home_summary.json
    row keeps them."""
    import json

    from typer.testing import CliRunner

    from homemodel.cli import app

    home = tmp_path / "home"
    home.mkdir()
    write_spec(home, _microwave_spec(MW_DOOR["thick"], 0.0, ("open_at_90", "free_corner")), "microwave.yaml")
    (home / "home.yaml").write_text(
        "apartment: {id: flat, name: Flat}\n"
        "rooms:\n  - id: kitchen\n    name: Kitchen\n    objects:\n"
        "      - {id: microwave_1, spec: microwave.yaml, pose: {xyz: [1.0, 1.0, 0.9]},\n"
        "         parking: [{name: front, xy: [1.8, 1.0], yaw_deg: 180}]}\n"
    )
    result = CliRunner().invoke(app, ["build", str(home), "--out", str(tmp_path / "out")], env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    said = " ".join(result.output.split())
    assert "microwave_1: warning: doors.0.hinge_measured: open_at_90 puts the hinge line" in said
    # The door given too thin, all in front, rubs its frame near the hinge line: the gate's warning too.
    assert "microwave_1: warning: collisions: rubs within 3 mm at a hinge line" in said
    (row,) = json.loads((tmp_path / "out" / "home_summary.json").read_text())["objects"]
    assert len(row["warnings"]) == 2 and "free_corner's line is used" in row["warnings"][0]
