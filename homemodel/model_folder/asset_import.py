"""Import an asset someone already has, whole: a PartNet-Mobility folder, a URDF (ours, or a
ROS description package's with `package://` DAE/STL meshes), or one mesh file (glb, glTF,
OBJ, STL, PLY, DAE) of a small object as a one-link model. What the import decides (the
frame it turns, the textures it drops) is said in `notes`; what the asset lacks for the gate
is in `gaps`, for `homemodel.model_folder.repair` to fill in and state.
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
import trimesh

from articulation.model import Collision, Link, Material, MeshGeometry, Model, Visual
from articulation.scan_model import LINK
from homemodel.core.checks import require_choice
from homemodel.core.errors import InputError
from homemodel.core.transforms import Y_UP_FROM_Z_UP
from homemodel.exchange.partnet import import_partnet, is_partnet_folder
from homemodel.exchange.urdf.read import MESH_FILE_SUFFIXES, find_urdf, load_urdf, read_mesh_parts
from homemodel.model_folder.repair import (
    AssetGaps,
    RepairOptions,
    find_gaps,
    model_flat_collisions,
    model_hollow_collisions,
    repair,
)
from homemodel.model_folder.write import ModelFolder, PipelineSummary, write_model_folder

_GLTF = (".glb", ".gltf")
# Metres per unit of a mesh file's coordinates. glTF is in metres by its specification and a
# DAE says its unit; OBJ, STL and PLY carry none.
UNIT_M = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254}
# A unitless mesh file read as metres is refused above this size: a downloaded cup in
# millimetres or centimetres would become an object tens of metres across.
MAX_UNITLESS_SIZE_M = 5.0


@dataclass(kw_only=True)
class ImportOptions:
    # Folders where `package://NAME/...` finds ROS package NAME (each a package, a folder of
    # packages, or an install prefix with share/NAME), after the package holding the URDF and
    # before those of ROS_PACKAGE_PATH and AMENT_PREFIX_PATH (as ROS 1 and 2 find packages).
    package_paths: list[Path] = field(default_factory=list)
    # A mesh file's up axis: "auto" is y for glTF (its specification says so), z otherwise.
    up_axis: Literal["auto", "y", "z"] = "auto"
    # A mesh file's unit: "auto" is metres for glTF (its specification) and DAE (scaled by its
    # <unit>); for OBJ, STL and PLY metres too, refused when that makes it over 5 m across.
    units: Literal["auto", "m", "cm", "mm", "in"] = "auto"

    def check(self) -> None:
        require_choice("up_axis", self.up_axis, ("auto", "y", "z"))
        require_choice("units", self.units, ("auto", *UNIT_M))


@dataclass(kw_only=True)
class ImportedAsset:
    model: Model
    kind: Literal["partnet", "urdf", "mesh"]
    gaps: AssetGaps  # what the gate needs and the asset lacks
    urdf: Path | None  # the asset's own URDF (None for a mesh file)
    notes: list[str] = field(default_factory=list)


def is_mesh_file(path: Path) -> bool:
    return Path(path).is_file() and Path(path).suffix.lower() in MESH_FILE_SUFFIXES


def import_asset(path: Path, options: ImportOptions | None = None, *, texture_dir: Path | None = None) -> ImportedAsset:
    """The asset at `path` as a model. Embedded textures of a mesh file are written into
    `texture_dir` (they must outlive the import until the model is exported); without it
    they are dropped, and the notes say so."""
    options = options or ImportOptions()
    options.check()
    path = Path(path)
    if is_mesh_file(path):
        return _import_mesh_file(path, options, texture_dir)
    if path.is_dir() and is_partnet_folder(path):
        urdf = find_urdf(path)
        imported = import_partnet(path)
        note = f"frame: PartNet-Mobility's y up turned to z up, the front (found from its {imported.front_from}) to +x, on the floor"
        return ImportedAsset(model=imported.model, kind="partnet", gaps=find_gaps(urdf, imported.model), urdf=urdf, notes=[note])
    if path.is_file() and path.suffix.lower() not in (".urdf", ".xacro"):
        raise InputError(f"{path}: expected a model folder, a .urdf or a mesh file ({', '.join(MESH_FILE_SUFFIXES)})")
    urdf = find_urdf(path)
    model = load_urdf(urdf, package_paths=options.package_paths)
    return ImportedAsset(model=model, kind="urdf", gaps=find_gaps(urdf, model), urdf=urdf)


@dataclass(kw_only=True)
class ImportedFolder:
    """An asset imported into a model folder (None when it has gaps and no repair was asked)."""

    imported: ImportedAsset
    folder: ModelFolder | None
    repairs: list[str]  # what the import decided (its notes), then each repair with its reason


def import_model_folder(
    path: Path,
    out_dir: Path,
    *,
    name: str,
    options: ImportOptions | None = None,
    repair_options: RepairOptions | None = None,
    force: bool = False,
) -> ImportedFolder:
    """Import the asset at `path` as model `name` into the model folder `out_dir` (written
    whole, the gate run on it). Gaps are filled as `repair_options` state; without them an
    asset with gaps is not written (`folder` None, `imported.gaps` says what it lacks)."""
    path = Path(path)
    start = time.perf_counter()
    # Embedded textures are written here by the import and read by the export.
    with tempfile.TemporaryDirectory(prefix="homemodel-import-") as textures:
        imported = import_asset(path, options, texture_dir=Path(textures))
        if imported.gaps and repair_options is None:
            return ImportedFolder(imported=imported, folder=None, repairs=[])
        model = imported.model
        model.name = name
        repairs = list(imported.notes)
        if imported.gaps:
            model, done = repair(model, imported.gaps, repair_options)
            repairs += done
        summary = PipelineSummary(
            source="imported",
            figures={"repairs": repairs},
            times_s={"import": time.perf_counter() - start},
            inputs={"asset": path},
        )
        folder = write_model_folder(model, out_dir, summary, force=force)
    return ImportedFolder(imported=imported, folder=folder, repairs=repairs)


def _up_axis(path: Path, options: ImportOptions) -> str:
    if options.up_axis != "auto":
        return options.up_axis
    return "y" if path.suffix.lower() in _GLTF else "z"


def _material(
    name: str, index: int, mesh: trimesh.Trimesh, texture_dir: Path | None, notes: list[str]
) -> tuple[Material, np.ndarray | None]:
    """Part `index`'s colour, and its texture (written into `texture_dir`) with its UVs."""
    visual = mesh.visual
    material = getattr(visual, "material", None)
    rgba = (0.8, 0.8, 0.8, 1.0)
    if material is not None and getattr(material, "main_color", None) is not None:
        rgba = tuple(float(c) / 255.0 for c in np.asarray(material.main_color, dtype=float)[:4])
    elif getattr(visual, "kind", None) == "vertex":
        rgba = tuple(float(c) / 255.0 for c in np.asarray(visual.vertex_colors, dtype=float).mean(axis=0)[:4])
    image = getattr(material, "baseColorTexture", None) or getattr(material, "image", None)
    uv = getattr(visual, "uv", None)
    if image is None or uv is None or len(uv) != len(mesh.vertices):
        return Material(name=name, rgba=rgba), None
    if texture_dir is None:
        notes.append(f"part {name!r}: its texture dropped (no folder to keep it in)")
        return Material(name=name, rgba=rgba), None
    texture = Path(texture_dir) / f"part{index}.png"  # not the part's name: it may hold any character
    image.convert("RGBA" if image.mode in ("RGBA", "LA", "P") else "RGB").save(texture)
    return Material(name=name, rgba=(1.0, 1.0, 1.0, rgba[3]), texture=texture), np.asarray(uv, dtype=np.float64)


def _apply_units(path: Path, parts: list[tuple[str, trimesh.Trimesh]], options: ImportOptions) -> str:
    """Scale the parts to metres as `options.units` says; the note that says how."""
    suffix = path.suffix.lower()
    if options.units != "auto":
        scale = UNIT_M[options.units]
        for _, mesh in parts:
            mesh.apply_scale(scale)
        return f"units: {options.units} (given), scaled by {scale:g} to metres"
    if suffix in _GLTF:
        return "units: metres (glTF's)"
    if suffix == ".dae":
        return "units: metres, by the file's <unit>"
    size_m = float(np.ptp(np.vstack([mesh.vertices for _, mesh in parts]), axis=0).max())
    if size_m > MAX_UNITLESS_SIZE_M:
        raise InputError(
            f"{path}: {size_m:.4g} units across, which as metres is no household object: "
            "give its units (--units mm, cm or in; manifest options: {units: mm})"
        )
    return f"units: metres (assumed: {suffix} files carry none; {size_m:.3g} m across)"


def _import_mesh_file(path: Path, options: ImportOptions, texture_dir: Path | None) -> ImportedAsset:
    """One link, `body` (as scanned objects' is named), holding the file's parts as visuals;
    z up; standing on the floor with its footprint centred on the origin."""
    try:
        parts = read_mesh_parts(path)
    except InputError as exc:
        raise InputError(str(exc) if str(exc).startswith(f"{path}:") else f"{path}: {exc}") from None
    units_note = _apply_units(path, parts, options)
    up = _up_axis(path, options)
    notes = [f"frame: {len(parts)} mesh part(s) as one link, " + ("y up (glTF's) turned to z up" if up == "y" else "z up as given"), units_note]
    z_up_from_file = np.linalg.inv(Y_UP_FROM_Z_UP) if up == "y" else np.eye(4)
    whole = trimesh.util.concatenate([trimesh.Trimesh(m.vertices, m.faces, process=False) for _, m in parts])
    whole.apply_transform(z_up_from_file)
    if whole.area <= 0:
        raise InputError(f"{path}: its triangles have no area")
    low, high = whole.bounds
    floor_from_file = np.eye(4)
    floor_from_file[:3, 3] = -np.array([(low[0] + high[0]) / 2, (low[1] + high[1]) / 2, low[2]])
    floor_from_file = floor_from_file @ z_up_from_file
    notes[0] += ", standing on the floor (z = 0) with its footprint centred on the origin"
    used: set[str] = set()
    visuals = []
    for index, (name, mesh) in enumerate(parts):
        label = name if name and name not in used else f"part{index}"
        used.add(label)
        material, uv = _material(label, index, mesh, texture_dir, notes)
        plain = trimesh.Trimesh(vertices=mesh.vertices, faces=mesh.faces, process=False)
        visuals.append(Visual(name=label, mesh=plain, material=material, uv=uv, link_from_visual=floor_from_file))
    whole.apply_translation(floor_from_file[:3, 3])
    # One convex collision shape (the exporters write the mesh's hull); the inertial is left
    # for the repair, which states the density and how the volume was had.
    link = Link(name=LINK, visuals=visuals, collisions=[Collision(name="hull", geometry=MeshGeometry(mesh=whole))])
    model = Model(name=path.stem, links=[link])
    gaps = AssetGaps(
        links_without_inertial=[LINK],
        limits_without_effort=[],
        limits_without_velocity=[],
        flat_collisions=model_flat_collisions(model),
        hollow_collisions=model_hollow_collisions(model),
    )
    return ImportedAsset(model=model, kind="mesh", gaps=gaps, urdf=None, notes=notes)
