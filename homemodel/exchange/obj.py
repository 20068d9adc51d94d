"""Wavefront OBJ + MTL writing for URDF visuals (pybullet and ROS tools read these), and a strict
OBJ reader for the files the gate and the URDF reader load."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from homemodel.core.errors import InputError
from homemodel.exchange.numbers import fixed
from homemodel.geometry.mesh_ops import zero_area_faces


def _fixed_rows(tag: str, values: np.ndarray) -> tuple[str, np.ndarray]:
    """One line `tag x y ...` per row of `values`, each number as `numbers.fixed` writes it
    (formatted in one call per block, not one per number), and the values a reader gets back."""
    values = np.asarray(values, dtype=np.float64)
    if len(values) == 0:
        return "", values
    text = ((tag + " %.6f" * values.shape[1] + "\n") * len(values)) % tuple(values.ravel().tolist())
    written = np.array(text.split(), dtype=object).reshape(len(values), -1)[:, 1:].astype(np.float64)
    # Every number has six decimals: dropping a zero before a separator six times removes the
    # trailing zeros and never reaches past the point, which goes next; "-0" can only be a whole number.
    for _ in range(6):
        text = text.replace("0 ", " ").replace("0\n", "\n")
    text = text.replace(". ", " ").replace(".\n", "\n").replace("-0 ", "0 ").replace("-0\n", "0\n")
    return text, written


def obj_text(mesh: trimesh.Trimesh, *, mtl_file: str | None, material: str | None, uv: np.ndarray | None) -> str:
    """An OBJ of `mesh` with one texture coordinate per vertex when `uv` is given. Triangles
    with no area at the written precision (marching cubes makes a few slivers that rounding
    to 1 um flattens) are left out: they carry no surface, and the gate refuses them."""
    vertex_lines, written = _fixed_rows("v", np.asarray(mesh.vertices).reshape(-1, 3))
    faces = np.asarray(mesh.faces)[~zero_area_faces(written, mesh.faces)] + 1
    parts = ["# homemodel\n"]
    if mtl_file is not None:
        parts.append(f"mtllib {mtl_file}\n")
    parts.append(vertex_lines)
    if uv is not None:
        parts.append(_fixed_rows("vt", np.asarray(uv).reshape(-1, 2))[0])
    if material is not None:
        parts.append(f"usemtl {material}\n")
    if len(faces):
        if uv is not None:
            parts.append(("f %d/%d %d/%d %d/%d\n" * len(faces)) % tuple(np.repeat(faces, 2, axis=1).ravel().tolist()))
        else:
            parts.append(("f %d %d %d\n" * len(faces)) % tuple(faces.ravel().tolist()))
    return "".join(parts)


def mtl_text(name: str, rgba: tuple[float, float, float, float], texture_file: str | None) -> str:
    r, g, b, a = rgba
    lines = [
        "# homemodel",
        f"newmtl {name}",
        f"Ka {fixed(r)} {fixed(g)} {fixed(b)}",
        f"Kd {fixed(r)} {fixed(g)} {fixed(b)}",
        "Ks 0 0 0",
        f"d {fixed(a)}",
        "illum 1",
    ]
    if texture_file is not None:
        lines.append(f"map_Kd {texture_file}")
    return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class ObjMesh:
    """What an OBJ file holds: `faces` index `vertices` (polygons fanned from their first corner);
    `face_texcoords` / `face_normals` index `texcoords` / `normals` where every corner has one."""

    vertices: np.ndarray  # (n, 3) float64
    faces: np.ndarray  # (m, 3) int64
    texcoords: np.ndarray  # (k, 2) float64
    normals: np.ndarray  # (j, 3) float64
    face_texcoords: np.ndarray | None
    face_normals: np.ndarray | None
    materials: tuple[str, ...]  # the `usemtl` names, in order of first use
    polygons: bool  # some face had more than three corners
    vertex_columns: int  # numbers on the widest `v` line (3; 4 with w; 6 with colours)

    def is_plain(self) -> bool:
        """Triangles of positions alone: what homemodel writes for collision hulls, and what
        trimesh reads to the same vertices and faces (it splits corners by uv and normal)."""
        return (
            not self.polygons
            and self.face_texcoords is None
            and self.face_normals is None
            and self.vertex_columns == 3
            and len(self.materials) <= 1
        )

    def trimesh(self, *, keep_unreferenced: bool) -> trimesh.Trimesh:
        """The triangles as trimesh's OBJ loader gives them for a plain file: vertices no face uses
        dropped (order kept) unless `keep_unreferenced` (its `maintain_order=True`)."""
        vertices, faces = self.vertices, self.faces
        if not keep_unreferenced:
            used = np.zeros(len(vertices), dtype=bool)
            used[faces] = True
            new_index = np.cumsum(used) - 1
            vertices, faces = vertices[used], new_index[faces]
        return trimesh.Trimesh(vertices=vertices.copy(), faces=faces, process=False)


# The statements of the OBJ format besides v, vt, vn and f: names, materials, free-form geometry.
_OTHER_STATEMENTS = set(
    "o g s mg usemtl mtllib l p vp cstype deg bmat step curv curv2 surf parm trim hole scrv sp end con "
    "bevel c_interp d_interp lod shadow_obj trace_obj ctech stech".split()
)


def read_obj(data: bytes, path: Path) -> ObjMesh:
    """The OBJ in `data` (the file at `path`), strictly: a malformed number, a face of fewer than
    three corners, an index of 0 or outside the elements read so far, or an unknown statement
    raises InputError "PATH: line N: problem". Negative indices count back from the last element
    read before the face, as the format says."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not UTF-8 text at byte {exc.start}") from None
    fast = _read_uniform(text)
    return fast if fast is not None else _read_lines(text.splitlines(), path)


def read_plain_obj(data: bytes, path: Path) -> ObjMesh | None:
    """The OBJ at `path` read strictly when it is plain (`ObjMesh.is_plain`, and no corner names a
    uv or normal); None for any other file, which trimesh reads (it splits such corners)."""
    if path.suffix.lower() != ".obj" or b"/" in data:
        return None
    obj = read_obj(data, path)
    return obj if obj.is_plain() else None


_UNIFORM_OTHERS = {"", "o", "g", "s", "mtllib", "usemtl", "vt", "vn"}  # uv and normals no corner uses


def _read_uniform(text: str) -> ObjMesh | None:
    """The common file (its `v` lines one run of three numbers each, its `f` lines one run of
    three positive plain indices each, nothing else but comments, names and materials) in a
    few whole-text calls; None for any other, which the line-by-line reader then reads or
    refuses with the line's number."""
    v_run, f_run = _run(text, "v "), _run(text, "f ")
    if v_run is None or f_run is None:
        return None
    (a, b), (c, d) = sorted((v_run, f_run))
    if c < b:
        return None
    materials: dict[str, None] = {}
    for line in (text[:a] + "\n" + text[b:c] + "\n" + text[d:]).splitlines():
        words = line.split(None, 1)
        if words and not words[0].startswith("#") and words[0] not in _UNIFORM_OTHERS:
            return None
        if words and words[0] == "usemtl":
            materials[words[1].strip() if len(words) > 1 else ""] = None
    vertices, corners = _run_table(text[slice(*v_run)], "v"), _run_table(text[slice(*f_run)], "f")
    if vertices is None or corners is None or len(materials) > 1:
        return None
    faces = corners.astype(np.int64) - 1
    if not np.array_equal(faces + 1, corners) or faces.min() < 0 or faces.max() >= len(vertices):
        return None
    return ObjMesh(vertices, faces, np.zeros((0, 2)), np.zeros((0, 3)), None, None, tuple(materials), False, 3)


def _run(text: str, tag: str) -> tuple[int, int] | None:
    """Where the lines starting with `tag` lie when they are one run of lines (as writers put
    them), as (start, end) in `text`; None when they are absent or mixed with other lines."""
    start = 0 if text.startswith(tag) else text.find("\n" + tag) + 1
    if start == 0 and not text.startswith(tag):
        return None
    last = text.rfind("\n" + tag) + 1
    end = text.find("\n", max(last, start))
    end = len(text) if end < 0 else end
    return (start, end) if text.count("\n", start, end) == text.count("\n" + tag, start, end) else None


def _run_table(run: str, tag: str) -> np.ndarray | None:
    """A run of `tag a b c` lines as an (n, 3) float array, or None if a line holds another count."""
    words = run.split()
    if "#" in run or "/" in run or len(words) != 4 * (run.count("\n") + 1) or set(words[::4]) != {tag}:
        return None
    del words[::4]
    try:  # float() parses a word several times faster than int() or numpy's string conversion
        return np.fromiter(map(float, words), np.float64, len(words)).reshape(-1, 3)
    except ValueError:
        return None


def _read_lines(lines: list[str], path: Path) -> ObjMesh:
    """Any OBJ, one line at a time, refusing what is malformed with the line's number."""
    elements: dict[str, list[list[float]]] = {"v": [], "vt": [], "vn": []}
    corners: list[list[tuple[int, int | None, int | None]]] = []
    materials: dict[str, None] = {}
    vertex_columns = 3
    for number, line in enumerate(lines, start=1):
        words = line.split("#", 1)[0].split()
        if not words:
            continue
        kind = words[0]
        where = f"{path}: line {number}"
        if kind in elements:
            width = {"v": (3, 4, 6, 7), "vt": (1, 2, 3), "vn": (3,)}[kind]
            if len(words) - 1 not in width:
                raise InputError(f"{where}: '{kind}' needs {' or '.join(map(str, width))} numbers, not {len(words) - 1}")
            try:
                values = [float(w) for w in words[1:]]
            except ValueError:
                raise InputError(f"{where}: '{kind}' has a value that is not a number: {line.strip()[:80]!r}") from None
            if kind == "v":
                vertex_columns = max(vertex_columns, len(values))
            elements[kind].append((values + [0.0, 0.0])[: 3 if kind != "vt" else 2])
        elif kind == "f":
            if len(words) < 4:
                raise InputError(f"{where}: a face needs at least three corners, not {len(words) - 1}")
            corners.append([_corner(w, elements, where) for w in words[1:]])
        elif kind == "usemtl" and len(words) > 1:
            materials[line.split(None, 1)[1].strip()] = None
        elif kind not in _OTHER_STATEMENTS:
            raise InputError(f"{where}: unknown OBJ statement {kind!r}")
    triangles = [(face[0], face[k], face[k + 1]) for face in corners for k in range(1, len(face) - 1)]
    if not triangles:
        raise InputError(f"{path}: the file holds no triangles")
    table = np.array([[c if c is not None else -1 for corner in tri for c in corner] for tri in triangles]).reshape(-1, 3, 3)
    face_tex = table[:, :, 1] if (table[:, :, 1] >= 0).all() else None
    face_norm = table[:, :, 2] if (table[:, :, 2] >= 0).all() else None
    v, vt, vn = (np.array(elements[k], dtype=np.float64).reshape(-1, 3 if k != "vt" else 2) for k in ("v", "vt", "vn"))
    polygons = any(len(face) > 3 for face in corners)
    return ObjMesh(v, table[:, :, 0], vt, vn, face_tex, face_norm, tuple(materials), polygons, vertex_columns)


def _corner(word: str, elements: dict[str, list], where: str) -> tuple[int, int | None, int | None]:
    """One face corner `v`, `v/vt`, `v//vn` or `v/vt/vn` as 0-based indices."""
    parts = word.split("/")
    if len(parts) > 3 or parts[0] == "" or (len(parts) == 3 and parts[1] == "" and parts[2] == ""):
        raise InputError(f"{where}: bad face corner {word!r}")
    indices: list[int | None] = []
    for kind, part in zip(("v", "vt", "vn"), parts):
        if part == "":
            indices.append(None)
            continue
        try:
            index = int(part)
        except ValueError:
            raise InputError(f"{where}: face corner {word!r} is not made of whole numbers") from None
        count = len(elements[kind])
        if index == 0 or not -count <= index <= count:
            raise InputError(f"{where}: face corner {word!r} names {kind} {index}, but {count} are defined before it")
        indices.append(index - 1 if index > 0 else count + index)
    indices += [None] * (3 - len(indices))
    return indices[0], indices[1], indices[2]
