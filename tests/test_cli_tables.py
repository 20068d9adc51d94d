"""The commands' tables in an 80-column terminal: ids and kinds stay whole, columns go instead."""

from __future__ import annotations

import pytest
from rich.console import Console

from homemodel.core.home_summary import ObjectRow
from homemodel.cli.build_command import build_table
from homemodel.cli.render_command import pictures_table
from modeller.comparison_picture import PictureRow

OBJECTS = [
    ("table_1", "table", "kitchen"),
    ("sugar_container", "sugar_container", "table_1"),
    ("pill_box", "pill_box", "cupboard_1"),
    ("washing_machine_2", "washing_machine", "bathroom"),
]


def rendered(table, width: int) -> str:  # noqa: ANN001
    console = Console(width=width, record=True, color_system=None)
    console.print(table)
    return console.export_text()


@pytest.mark.parametrize("width", [80, 120])
def test_the_build_table_keeps_ids_and_kinds_whole(width: int) -> None:
    rows = [
        ObjectRow(
            id=object_id,
            category=kind,
            spec=f"{object_id}.yaml",
            parent=parent,
            links=5,
            joints=12,
            grasp_points=11,
            triangles=123_456,
            valid=True,
            times_s={"build": 0.31, "export": 0.1, "validate": 0.98},
        )
        for object_id, kind, parent in OBJECTS
    ]
    text = rendered(build_table(Console(width=width), "homemodel build examples/kitchen", rows), width)
    assert "…" not in text and max(len(line) for line in text.splitlines()) <= width
    for object_id, kind, parent in OBJECTS:
        assert f" {object_id} " in text and f" {kind} " in text and f" {parent} " in text
    assert "joints" in text and "valid" in text
    assert ("check s" in text) == (width == 120)


def test_the_render_table_keeps_names_whole_at_80_columns() -> None:
    rows = [
        PictureRow(
            photo="examples/textured/photos/cupboard_door.jpg",
            part="door_0_handle",
            face="front",
            texture_px=(1024, 768),
            texture_kb=55.0,
            focal_px=700.0,
            reprojection_px=0.12,
            picture="comparison_0.png",
        )
    ]
    text = rendered(pictures_table(Console(width=80), "homemodel render cupboard.yaml", rows), 80)
    assert "…" not in text and max(len(line) for line in text.splitlines()) <= 80
    for name in ("cupboard_door.jpg", "door_0_handle", "front", "comparison_0.png", "0.12"):
        assert name in text
