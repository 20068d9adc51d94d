"""`homemodel build --force` over an earlier output reuses the objects whose content key is
unchanged and rebuilds the rest, with the same map."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from homemodel.cli import app

pytestmark = pytest.mark.bpy
KITCHEN = Path(__file__).resolve().parents[1] / "examples" / "kitchen"
HOME = """apartment: {id: flat, name: Flat}
rooms:
  - id: kitchen
    name: Kitchen
    objects:
      - id: table_1
        spec: table.yaml
        parking: [{name: south, xy: [0.0, -1.0], yaw_deg: 90}]
        objects:
          - {id: red_cup, spec: red_cup.yaml, relation: "on", pose: {xyz: [0.1, 0.0, 0.75]}}
"""


def _objects(map_path: Path) -> dict:
    from homemodel.exchange.map_xml import load_map

    return {o.id: (o.type, len(o.grasp_points), len(getattr(o, "joints", []))) for o in load_map(map_path).objects()}


def test_a_forced_rebuild_reuses_what_did_not_change(tmp_path: Path) -> None:
    example = tmp_path / "home"
    example.mkdir()
    for name in ("table.yaml", "red_cup.yaml"):
        shutil.copy(KITCHEN / name, example / name)
    (example / "home.yaml").write_text(HOME)
    out = tmp_path / "out"
    runner = CliRunner()
    first = runner.invoke(app, ["build", str(example), "--out", str(out)])
    assert first.exit_code == 0, first.output
    map_before = _objects(out / "map.xml")
    again = runner.invoke(app, ["build", str(example), "--out", str(out), "--force"])
    assert again.exit_code == 0 and "reused unchanged from the earlier output: table_1, red_cup" in again.output
    # The same objects (the reused ones read back from their URDF, whose angles are rounded).
    assert _objects(out / "map.xml") == map_before
    cup = example / "red_cup.yaml"
    cup.write_text(cup.read_text().replace("height_m: 0.095", "height_m: 0.1"))
    changed = runner.invoke(app, ["build", str(example), "--out", str(out), "--force"])
    assert changed.exit_code == 0, changed.output
    rows = {r["id"]: r for r in json.loads((out / "home_summary.json").read_text())["objects"]}
    assert rows["table_1"]["cached"] and not rows["red_cup"]["cached"]
    for name in ("model.urdf", "model.glb", "model.blend", "content_key.txt"):
        assert (out / "models/red_cup" / name).is_file()
