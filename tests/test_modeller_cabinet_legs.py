"""A cabinet on four legs (a bedside table's) built from the spec's `legs`, not as a plinth.

The real table is trimesh boxes placed here: a carcass standing on four 35 mm square legs
in its corners. It is read by tape (to the millimetre) into a spec and rebuilt; the built
legs stand where the real ones do, and a camera looking under the carcass sees through
between them, as it does under the real one (a plinth in their place had `map observe`
write such a table 59 mm off and its drawer at its limit, issue 26's check).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh
from spec_edits import with_field, write_spec

from homemodel.core.errors import SpecError
from modeller.spec_loading import load_spec

TAPE_STEP_M = 0.001
WIDTH, DEPTH, HEIGHT, LEG_HEIGHT, LEG, LEG_INSET = 0.462, 0.384, 0.604, 0.117, 0.035, 0.0125


def _read(value_m: float) -> float:
    return round(round(value_m / TAPE_STEP_M) * TAPE_STEP_M, 6)


def _real_legs() -> list[trimesh.Trimesh]:
    """The four real legs, in the table's frame (x forward, origin on the floor under the
    footprint's centre)."""
    x, y = DEPTH / 2 - LEG_INSET - LEG / 2, WIDTH / 2 - LEG_INSET - LEG / 2
    return [
        trimesh.creation.box(extents=(LEG, LEG, LEG_HEIGHT), transform=trimesh.transformations.translation_matrix(
            (sx * x, sy * y, LEG_HEIGHT / 2)))
        for sx in (-1, 1) for sy in (-1, 1)
    ]


def _spec() -> dict:
    """The installer's spec: the legs' height as the plinth's, their section and inset by tape."""
    return {"kind": "cupboard", "width_m": _read(WIDTH), "depth_m": _read(DEPTH), "height_m": _read(HEIGHT),
            "plinth_height_m": _read(LEG_HEIGHT), "legs": {"size_m": _read(LEG), "inset_m": _read(LEG_INSET)},
            "doors": [{"hinge": "right", "left_m": 0.002, "width_m": _read(WIDTH - 0.004),
                       "bottom_m": _read(LEG_HEIGHT + 0.002), "height_m": _read(HEIGHT - LEG_HEIGHT - 0.004)}],
            "drawers": []}


@pytest.mark.bpy
def test_a_cabinet_on_legs_is_built_with_legs_where_the_real_ones_stand(tmp_path: Path) -> None:
    from modeller import build_model

    model = build_model(write_spec(tmp_path, _spec()))
    world = model.world_from_links()
    body = trimesh.util.concatenate(
        [v.mesh.copy().apply_transform(world["body"] @ v.link_from_visual) for v in model.link("body").visuals]
    )
    # What stands under the carcass: in each corner, a leg from the floor where the real one is.
    under = body.vertices[body.vertices[:, 2] < LEG_HEIGHT - 0.002]
    for leg in _real_legs():
        mine = under[np.all(np.sign(under[:, :2]) == np.sign(leg.centroid[:2]), axis=1)]
        assert np.allclose([mine.min(0)[:2], mine.max(0)[:2]], leg.bounds[:, :2], atol=TAPE_STEP_M)
        assert mine[:, 2].min() == pytest.approx(0.0, abs=1e-6)
    # Looking in under the carcass, between the front legs, a camera sees through to the wall.
    rays = trimesh.ray.ray_triangle.RayMeshIntersector(body)
    origins = np.array([[1.0, y, z] for y in np.linspace(-0.15, 0.15, 7) for z in (0.03, 0.06, 0.09)])
    assert not rays.intersects_any(origins, np.tile((-1.0, 0.0, 0.0), (len(origins), 1))).any()
    # The collisions are the legs too.
    assert sorted(c.name for c in model.link("body").collisions if c.name.startswith("leg_")) == [
        f"leg_{k}" for k in range(4)
    ]


def test_legs_refuse_a_cabinet_without_their_height_and_legs_too_thick_for_it(tmp_path: Path) -> None:
    data = _spec()
    load_spec(write_spec(tmp_path, data))
    cases = [
        ("plinth_height_m", 0.0, r"legs: legs stand under the carcass: give their height as plinth_height_m"),
        ("legs.size_m", 0.2, r"legs\.inset_m: legs 0\.2 m thick, 0\.012 m in from the edges, do not fit under a "
                             r"cupboard 0\.384 m across"),
    ]
    for dotted, value, message in cases:
        with pytest.raises(SpecError, match=message):
            load_spec(write_spec(tmp_path, with_field(data, dotted, value), "case.yaml"))
