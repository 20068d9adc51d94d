"""The independent check's stand-in for `map observe`: real pieces (`unseen_pieces`: their
truth meshes, plinths, face frames, thick doors partly in their recess, door bins, drawer
boxes, knobs in pockets) stand in a row along a wall; the map holds the models `homemodel
build` makes from the specs an installer's tape gives for them. Views are rendered from the
truth meshes, each moving part turned or slid about its real axis (not the model's), so the
models differ from what the camera sees as real furniture differs from its measurements.

    scene = RealPieceScene.of(map_path, pieces)    # the map's scene, its objects' parts the real ones
    ViewSimulator(scene).render(camera, map_from_camera, ViewOptions(...))

`fitted_out(pieces)` adds what an installer's spec leaves out: handles, rounded front edges,
tapered knobs.
"""

from __future__ import annotations

import copy
import shutil
from pathlib import Path

import numpy as np
import trimesh
import yaml
from unseen_pieces import MAKERS, Mover, RealPiece

from homemodel.core.transforms import transform_from_xyz_rpy
from prior_maps import write_prior_map
from tracking.report import ObjectReport
from tracking.scene import HomeScene, Part

# (map id, maker, seed) left to right along the wall at x = 0, fronts facing +x.
ROW = [
    ("wardrobe_4", "cabinet", 4), ("cupboard_14", "cabinet", 14), ("dishwasher_3", "dishwasher", 3),
    ("drawers_21", "cabinet", 21), ("oven_3", "oven", 3), ("fridge_3", "fridge", 3),
    ("cupboard_35", "cabinet", 35), ("cupboard_34", "cabinet", 34),
]
# (map id, maker, seed, the piece it stands on or hangs above)
ABOVE = [("microwave_3", "microwave", 3, "cupboard_35"), ("wall_6", "cabinet", 6, "drawers_21")]
GAP_M = 0.006  # between neighbours in the row
BODY_RGB, FRONT_RGB = (0.85, 0.84, 0.8), (0.55, 0.42, 0.3)


def real_pieces() -> dict[str, RealPiece]:
    return {oid: MAKERS[maker](seed) for oid, maker, seed, *_ in ROW + ABOVE}


def fitted_out(pieces: dict[str, RealPiece], seed: int = 0) -> dict[str, RealPiece]:
    """Copies of `pieces` as they stand in a kitchen, with what the installer's spec leaves
    out (`handle: none`): every door and drawer front but a microwave's with a bar handle or
    a mushroom knob near its free edge, its front edges rounded (4 mm), and the appliances'
    knobs tapered to a rounded top instead of plain cylinders."""
    rng = np.random.default_rng(seed)
    out = {}
    for object_id, piece in pieces.items():
        piece = out[object_id] = copy.deepcopy(piece)
        bar = bool(rng.random() < 0.6)
        piece.body = [_tapered(mesh) if _is_knob(mesh) else mesh for mesh in piece.body]
        for mover in piece.movers:
            if mover.joint.startswith(("door", "drawer")):
                front = mover.boxes[0].bounds
                mover.boxes[0] = _rounded_slab(front, FRONT_EDGE_M)
                if piece.spec["kind"] != "microwave":
                    mover.boxes += _handle(front, mover.axis, bar)
    return out


GLASS_MARGIN_M = 0.06  # a glazed door's frame round its pane


def glazed(pieces: dict[str, RealPiece], object_id: str, joint: str) -> dict[str, RealPiece]:
    """`pieces` with a copy of `object_id`'s door on `joint` glazed, as a glass-fronted
    cabinet's: its front a frame GLASS_MARGIN_M wide round a pane the sensor sees through (no
    reading of its own). Its spec, and so its model, keep a solid door."""
    out = dict(pieces)
    piece = out[object_id] = copy.deepcopy(pieces[object_id])
    mover = next(m for m in piece.movers if m.joint == joint)
    (x0, y0, z0), (x1, y1, z1) = mover.boxes[0].bounds
    m = GLASS_MARGIN_M
    mover.boxes[:1] = [trimesh.creation.box(bounds=b) for b in (
        [(x0, y0, z0), (x1, y0 + m, z1)], [(x0, y1 - m, z0), (x1, y1, z1)],
        [(x0, y0 + m, z0), (x1, y1 - m, z0 + m)], [(x0, y0 + m, z1 - m), (x1, y1 - m, z1)])]
    return out


FRONT_EDGE_M = 0.004  # the radius of a front's rounded edges


def _rounded_slab(bounds: np.ndarray, radius: float) -> trimesh.Trimesh:
    """A box whose four edges round its front face (+x) have the given radius."""
    (x0, y0, z0), (x1, y1, z1) = bounds
    turn = np.linspace(0.0, np.pi / 2, 5)
    back, inset = radius * (1 - np.sin(turn)), radius * (1 - np.cos(turn))  # set back from x1, in from the sides
    points = [(x0, y, z) for y in (y0, y1) for z in (z0, z1)]
    points += [(x1 - b, y, z) for b, i in zip(back, inset) for y in (y0 + i, y1 - i) for z in (z0 + i, z1 - i)]
    return trimesh.convex.convex_hull(np.array(points))


def _round(x0: float, x1: float, radius: float, centre_yz, sections: int = 32) -> np.ndarray:
    """Points of a circle about the x axis through `centre_yz` at x0 and at x1."""
    angles = np.linspace(0.0, 2 * np.pi, sections, endpoint=False)
    ring = np.stack([np.cos(angles), np.sin(angles)], 1) * radius + centre_yz
    return np.concatenate([np.column_stack([np.full(sections, x), ring]) for x in (x0, x1)])


def _solid(*rounds: np.ndarray) -> trimesh.Trimesh:
    return trimesh.convex.convex_hull(np.concatenate(rounds))


def _is_knob(mesh: trimesh.Trimesh) -> bool:
    """An appliance's knob: a round body part (not a box) about an axis along x."""
    extents = mesh.extents
    return len(mesh.vertices) > 8 and abs(extents[1] - extents[2]) < 1e-3 and extents[0] < extents[1] * 1.5


def _tapered(knob: trimesh.Trimesh) -> trimesh.Trimesh:
    """The knob's cylinder as a real knob: full width behind, tapering to 70 % at a rounded top."""
    (x0, y0, z0), (x1, y1, z1) = knob.bounds
    radius, centre, length = (y1 - y0) / 2, ((y0 + y1) / 2, (z0 + z1) / 2), x1 - x0
    return _solid(_round(x0, x0 + 0.5 * length, radius, centre), _round(x1 - 0.12 * length, x1 - 0.12 * length, 0.85 * radius, centre),
                  _round(x1, x1, 0.7 * radius, centre))


def _handle(front: np.ndarray, axis, bar: bool) -> list[trimesh.Trimesh]:
    """A bar handle (12 mm, 34 mm proud on two posts) or a mushroom knob (30 mm, 28 mm proud)
    on a front: centred on a drawer, near the free edge of a door."""
    (_, y0, z0), (x1, y1, z1) = front
    centre, along_z = np.array([(y0 + y1) / 2, (z0 + z1) / 2]), False
    if axis is not None:
        point, direction = axis
        if abs(direction[2]) > 0.5:  # a side hinge: near the far side, a third of the way down a tall door
            far = y1 if abs(point[1] - y0) < abs(point[1] - y1) else y0
            centre = np.array([far - np.sign(far - point[1]) * 0.05, z0 + 0.45 * (z1 - z0) if z1 - z0 > 1.0 else (z0 + z1) / 2])
            along_z = True
        else:  # a flap: near the edge far from the hinge line
            far = z1 if abs(point[2] - z0) < abs(point[2] - z1) else z0
            centre[1] = far - np.sign(far - point[2]) * 0.04
    if not bar:
        return [_solid(_round(x1, x1 + 0.02, 0.006, centre)), _solid(_round(x1 + 0.018, x1 + 0.028, 0.015, centre))]
    length = min(0.3, 0.5 * (z1 - z0)) if along_z else min(0.4, 0.6 * (y1 - y0))
    step = np.array([0.0, length / 2]) if along_z else np.array([length / 2, 0.0])
    posts = [_solid(_round(x1, x1 + 0.022, 0.005, centre + s * 0.9 * step)) for s in (-1, 1)]
    return posts + [_box_between(x1 + 0.022, x1 + 0.034, centre - step - 0.006, centre + step + 0.006)]


def _box_between(x0: float, x1: float, low_yz: np.ndarray, high_yz: np.ndarray) -> trimesh.Trimesh:
    low, high = np.array([x0, *low_yz]), np.array([x1, *high_yz])
    return trimesh.creation.box(extents=high - low, transform=trimesh.transformations.translation_matrix((low + high) / 2))


def write_room(folder: Path, pieces: dict[str, RealPiece]) -> Path:
    """The specs and `home.yaml` an installer writes for the room; returns the folder."""
    folder.mkdir(parents=True, exist_ok=True)
    poses, y = {}, 0.4
    for oid, *_ in ROW:
        spec = pieces[oid].spec
        poses[oid] = (spec["depth_m"] / 2, y + spec["width_m"] / 2, 0.0)
        y += spec["width_m"] + GAP_M
    for oid, _, _, under in ABOVE:
        spec = pieces[oid].spec
        # A microwave stands on its piece; a wall cabinet's spec holds its height.
        z = pieces[under].spec["height_m"] if spec["kind"] == "microwave" else 0.0
        poses[oid] = (spec["depth_m"] / 2, poses[under][1], z)
    objects = []
    for oid, piece in pieces.items():
        (folder / f"{oid}.yaml").write_text(yaml.safe_dump(piece.spec))
        x, y_m, z = (round(v, 4) for v in poses[oid])
        objects.append({"id": oid, "spec": f"{oid}.yaml", "pose": {"xyz": [x, y_m, z], "rpy_deg": [0, 0, 0]},
                        "parking": [{"name": "front", "xy": [round(x + 1.2, 3), y_m], "yaw_deg": 180}]})
    home = {"apartment": {"id": "real_house", "name": "Real house"},
            "rooms": [{"id": "kitchen", "name": "Kitchen", "objects": objects,
                       "outline": [[0.0, 0.0], [5.0, 0.0], [5.0, round(y + 0.6, 3)], [0.0, round(y + 0.6, 3)]]}]}
    (folder / "home.yaml").write_text(yaml.safe_dump(home, sort_keys=False))
    return folder


def built_home(specs: Path, name: str, out: Path) -> Path:
    """`homemodel build` of a folder of specs (with its `home.yaml`), made once per content
    (`fixture_cache`) and copied to `out`; returns the map."""
    from fixture_cache import cached_folder, content_key
    from typer.testing import CliRunner

    from homemodel.cli import app

    def build(folder: Path) -> None:
        result = CliRunner().invoke(app, ["build", str(specs), "--out", str(folder / "out")])
        assert result.exit_code == 0, result.output

    key = content_key(inputs=[specs], packages=("homemodel", "modeller", "articulation", "semantic_map"))
    shutil.copytree(cached_folder(name, key, build) / "out", out)
    return out / "map.xml"


def real_move(mover: Mover, position: float) -> np.ndarray:
    """The real part's motion at a joint position (rad or m, as the model's joint reads):
    along or about its real axis, a share of its move at the limit."""
    at_limit = np.asarray(mover.at_limit, dtype=float)
    if np.allclose(at_limit[:3, :3], np.eye(3)):
        move = np.eye(4)
        move[:3, 3] = at_limit[:3, 3] * position / mover.limit
        return move
    angle, direction, point = trimesh.transformations.rotation_from_matrix(at_limit)
    return trimesh.transformations.rotation_matrix(angle * position / mover.limit, direction, point)


def _part(object_id: str, link: str, joint: str | None, meshes: list[trimesh.Trimesh], rgb) -> Part:
    mesh = trimesh.util.concatenate(meshes)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    return Part(object_id=object_id, link=link, joint=joint, vertices_link=np.asarray(mesh.vertices, dtype=np.float64),
                faces=faces, face_rgb=np.tile(np.asarray(rgb, dtype=np.float64), (len(faces), 1)))


class RealPieceScene(HomeScene):
    """The map's scene whose objects are the real pieces, posed by their real joints (a real
    knob is part of the body: the truth's knob positions are the map's)."""

    movers: dict[tuple[str, str], Mover]

    @classmethod
    def of(cls, map_path: Path, pieces: dict[str, RealPiece]) -> RealPieceScene:
        models = HomeScene.load(map_path)
        scene = cls(map_path=models.map_path, smap=models.smap, objects=models.objects, parts=[])
        scene.movers = {}
        for object_id, obj in models.objects.items():
            piece = pieces[object_id]
            root = next(p.link for p in models.parts if p.object_id == object_id and p.joint is None)
            scene.parts.append(_part(object_id, root, None, piece.body, BODY_RGB))
            for mover in piece.movers:
                scene.parts.append(_part(object_id, mover.link, mover.joint, mover.boxes, FRONT_RGB))
                scene.movers[(object_id, mover.link)] = mover
        scene.parts += [p for p in models.parts if p.object_id is None]  # the floor and walls
        return scene

    def pose(self, joint_positions=None, map_from_objects=None) -> list[np.ndarray]:
        positions = self.checked_joint_positions(joint_positions)
        objects = self.map_from_objects(map_from_objects)
        poses = []
        for part in self.parts:
            if part.object_id is None:
                poses.append(np.eye(4))
            elif part.joint is None:
                poses.append(objects[part.object_id])
            else:
                mover = self.movers[(part.object_id, part.link)]
                poses.append(objects[part.object_id] @ real_move(mover, positions[part.object_id][mover.joint]))
        return poses


def pose_errors(obj: ObjectReport, true_pose: np.ndarray) -> tuple[tuple[float, float], tuple[float, float]]:
    """((the map's, the written) origin error in m, (the map's, the written) turn error in deg)."""
    errors = [np.linalg.inv(true_pose) @ p for p in (obj.previous_map_from_object, obj.map_from_object)]
    shifts = tuple(float(np.linalg.norm(e[:2, 3])) for e in errors)
    turns = tuple(abs(float(np.degrees(np.arctan2(e[1, 0], e[0, 0])))) for e in errors)
    return shifts, turns


def write_prior(map_path: Path, offsets: dict[str, tuple[float, float, float]], out: Path) -> Path:
    """The map with the objects in `offsets` ({id: (x m, y m, yaw deg) in its own frame}) off."""
    return write_prior_map(map_path, {oid: transform_from_xyz_rpy((x, y, 0.0), (0.0, 0.0, np.radians(yaw)))
                                      for oid, (x, y, yaw) in offsets.items()}, out)
