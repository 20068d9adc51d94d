"""The independent check's stand-in for `map observe`: real pieces (`unseen_pieces`: their
truth meshes, plinths, face frames, thick doors partly in their recess, door bins, drawer
boxes, knobs in pockets) stand in a row along a wall; the map holds the models `homemodel
build` makes from the specs an installer's tape gives for them. Views are rendered from the
truth meshes, each moving part turned or slid about its real axis (not the model's), so the
models differ from what the camera sees as real furniture differs from its measurements.

    scene = RealPieceScene.of(map_path, pieces)    # the map's scene, its objects' parts the real ones
    ViewSimulator(scene).render(camera, map_from_camera, ViewOptions(...))
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import trimesh
import yaml
from unseen_pieces import MAKERS, Mover, RealPiece

from homemodel.core.transforms import transform_from_xyz_rpy
from prior_maps import write_prior_map
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


def write_prior(map_path: Path, offsets: dict[str, tuple[float, float, float]], out: Path) -> Path:
    """The map with the objects in `offsets` ({id: (x m, y m, yaw deg) in its own frame}) off."""
    return write_prior_map(map_path, {oid: transform_from_xyz_rpy((x, y, 0.0), (0.0, 0.0, np.radians(yaw)))
                                      for oid, (x, y, yaw) in offsets.items()}, out)
