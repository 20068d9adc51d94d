"""How a homemodel model lives in a .blend, and the model document it reads and writes.

The scheme (Phobos and LinkForge style: empties with custom properties, which survive save
and reopen and which Blender's glTF exporter writes as node `extras`):

- Every link is an empty with `hm_link` (its name). Its collisions (`hm_collisions`) and
  inertial (`hm_inertial`) are JSON text on it. The root link also holds `hm_model` (JSON:
  name, category, affordances, properties) and, when built from measurements, `hm_spec`.
- A link moved by a joint is the child of its parent link's empty and holds the joint:
  `hm_joint` (name), `hm_joint_type`, `hm_axis`, `hm_lower`, `hm_upper`, `hm_effort`,
  `hm_velocity`, `hm_states` (JSON list of {name, position}), `hm_dynamics` (JSON) and
  `hm_q`, the joint's position (rad or m): the slider. Its parent inverse matrix is the
  joint origin (`parent_from_joint`); drivers turn `hm_q` into a rotation about, or a
  translation along, `hm_axis`, so the viewport moves the way the URDF says.
- Every mesh object under a link (and not under another link) is a visual of it, its colour
  its material's viewport colour. Every empty with `hm_grasp` (name; `hm_grasp_kind`) under
  a link is a grasp point.

Reading back uses world matrices, so whatever the installer moved, added or reshaped
(a handle, a shelf parented to a link, a mesh edit) is what gets exported.
"""

from __future__ import annotations

import json
import math
import os

import bpy
from mathutils import Matrix, Vector

# These spell out homemodel.exchange.blender_document, which the add-on may not import (a test checks).
MODEL_FORMAT = "homemodel.blender-model/1"
MODEL = "hm_model"
SPEC = "hm_spec"
LINK = "hm_link"
COLLISIONS = "hm_collisions"
INERTIAL = "hm_inertial"
JOINT = "hm_joint"
JOINT_TYPE = "hm_joint_type"
AXIS = "hm_axis"
LOWER = "hm_lower"
UPPER = "hm_upper"
EFFORT = "hm_effort"
VELOCITY = "hm_velocity"
STATES = "hm_states"
DYNAMICS = "hm_dynamics"
POSITION = "hm_q"
GRASP = "hm_grasp"
GRASP_KIND = "hm_grasp_kind"
FROM_MESHES = "from_meshes"
# As articulation.joint_types names them (the add-on may not import it; a test checks).
JOINT_TYPES = ("revolute", "prismatic", "continuous", "fixed")
LIMITED_JOINT_TYPES = ("revolute", "prismatic")  # with a <limit lower upper>
ROTATING_JOINT_TYPES = ("revolute", "continuous")
# A continuous joint's slider still needs an end: one turn either way.
CONTINUOUS_RANGE_RAD = 2 * math.pi


def matrix_of(rows) -> Matrix:
    return Matrix([list(map(float, row)) for row in rows])


def rows_of(matrix: Matrix) -> list[list[float]]:
    return [list(row) for row in matrix]


def rigid(matrix: Matrix) -> Matrix:
    """`matrix` without its scale: rotation and translation only."""
    rigid = matrix.to_quaternion().to_matrix().to_4x4()
    rigid.translation = matrix.translation
    return rigid


def _material(name: str, rgba, texture: str | None = None) -> bpy.types.Material:
    material = bpy.data.materials.get(name)
    if material is not None and _same_colour(material.diffuse_color, rgba) and _texture_path(material) == texture:
        return material
    material = bpy.data.materials.new(name)
    material.diffuse_color = [float(c) for c in rgba]
    if texture is not None and material.node_tree is None:
        material.use_nodes = True  # Blender 3.x and 4.x; 5.0's materials always have nodes
    tree = material.node_tree
    principled = tree.nodes.get("Principled BSDF") if tree is not None else None
    if principled is not None:  # what Blender's glTF exporter and renderer read
        principled.inputs["Base Color"].default_value = [float(c) for c in rgba]
        principled.inputs["Alpha"].default_value = float(rgba[3])
        if texture is not None:
            image = tree.nodes.new("ShaderNodeTexImage")
            image.image = bpy.data.images.load(texture, check_existing=True)
            tree.links.new(image.outputs["Color"], principled.inputs["Base Color"])
    return material


def _same_colour(a, b) -> bool:
    return tuple(round(float(c), 4) for c in a) == tuple(round(float(c), 4) for c in b)


def _texture_path(material: bpy.types.Material | None) -> str | None:
    """The image file the material's base colour reads, if it is one on disk (a packed or
    painted image is not: the model keeps the flat colour)."""
    tree = material.node_tree if material is not None else None
    principled = tree.nodes.get("Principled BSDF") if tree is not None else None
    if principled is None:
        return None
    for link in principled.inputs["Base Color"].links:
        node = link.from_node
        if node.type == "TEX_IMAGE" and node.image is not None and node.image.source == "FILE" and not node.image.packed_file:
            path = bpy.path.abspath(node.image.filepath)
            return path if os.path.isfile(path) else None
    return None


def _mesh_object(name: str, visual: dict, collection: bpy.types.Collection) -> bpy.types.Object:
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(v) for v in visual["vertices"]], [], [tuple(f) for f in visual["faces"]])
    texture = visual.get("texture")
    if texture is not None:  # the document's UVs are per vertex; Blender's per face corner
        uv = visual["uv"]
        corners = [0] * len(mesh.loops)
        mesh.loops.foreach_get("vertex_index", corners)
        mesh.uv_layers.new(name="UVMap").data.foreach_set("uv", [c for i in corners for c in uv[i]])
    mesh.update()
    mesh.materials.append(_material(visual.get("material") or visual["name"], visual.get("rgba", (0.8, 0.8, 0.8, 1.0)), texture))
    obj = bpy.data.objects.new(name, mesh)
    collection.objects.link(obj)
    return obj


def _add_driver(obj: bpy.types.Object, path: str, index: int, expression: str, variables: dict[str, str]) -> None:
    driver = obj.driver_add(path, index).driver
    driver.type = "SCRIPTED"
    for name, data_path in variables.items():
        variable = driver.variables.new()
        variable.name = name
        variable.type = "SINGLE_PROP"
        variable.targets[0].id = obj
        variable.targets[0].data_path = data_path
    driver.expression = expression  # simple expressions run without Python auto-exec


def joint_range(obj: bpy.types.Object) -> tuple[float, float]:
    if obj[JOINT_TYPE] == "continuous":
        return -CONTINUOUS_RANGE_RAD, CONTINUOUS_RANGE_RAD
    if obj[JOINT_TYPE] == "fixed":
        return 0.0, 0.0
    return float(obj.get(LOWER, 0.0)), float(obj.get(UPPER, 0.0))


def set_position(obj: bpy.types.Object, position: float) -> None:
    """Move the joint on `obj` to `position`, kept within its range."""
    lower, upper = joint_range(obj)
    obj[POSITION] = min(max(float(position), lower), upper)
    obj.update_tag()  # a property set from Python does not tell the drivers by itself


def rig_joint(obj: bpy.types.Object) -> None:
    """(Re)make the drivers and the slider's range of the joint on `obj` from its properties."""
    obj.driver_remove("rotation_axis_angle")
    obj.driver_remove("location")
    obj.rotation_mode = "AXIS_ANGLE"
    obj.rotation_axis_angle = (0.0, 0.0, 0.0, 1.0)
    obj.location = (0.0, 0.0, 0.0)
    kind = obj[JOINT_TYPE]
    lower, upper = joint_range(obj)
    obj[POSITION] = min(max(float(obj.get(POSITION, 0.0)), lower), upper)
    obj.id_properties_ui(POSITION).update(
        min=lower, max=upper, soft_min=lower, soft_max=upper,
        subtype="DISTANCE" if kind == "prismatic" else "ANGLE",
        description=f"{obj[JOINT]}: {kind} joint position",
    )
    if kind in ROTATING_JOINT_TYPES:
        _add_driver(obj, "rotation_axis_angle", 0, "q", {"q": f'["{POSITION}"]'})
        for i in range(3):
            _add_driver(obj, "rotation_axis_angle", i + 1, "a", {"a": f'["{AXIS}"][{i}]'})
    elif kind == "prismatic":
        for i in range(3):
            _add_driver(obj, "location", i, "q*a", {"q": f'["{POSITION}"]', "a": f'["{AXIS}"][{i}]'})


def _set_joint(obj: bpy.types.Object, joint: dict, parent: bpy.types.Object) -> None:
    obj.parent = parent
    obj.matrix_parent_inverse = matrix_of(joint["parent_from_joint"])
    obj[JOINT] = joint["name"]
    obj[JOINT_TYPE] = joint["type"]
    obj[AXIS] = [float(v) for v in joint.get("axis", (0.0, 0.0, 1.0))]
    limits = joint.get("limits")
    if limits is not None:  # a continuous or fixed joint may have none, and keeps none
        obj[LOWER] = float(limits.get("lower", 0.0))
        obj[UPPER] = float(limits.get("upper", 0.0))
        obj[EFFORT] = float(limits.get("effort", 10.0))
        obj[VELOCITY] = float(limits.get("velocity", 1.0))
    obj[STATES] = json.dumps(joint.get("states", []))
    if joint.get("dynamics") is not None:
        obj[DYNAMICS] = json.dumps(joint["dynamics"])
    obj[POSITION] = 0.0
    rig_joint(obj)


def add_model(doc: dict, collection: bpy.types.Collection, world_from_model: Matrix | None = None) -> bpy.types.Object:
    """Put the model a document describes into `collection`; returns its root link's empty."""
    if doc.get("format") != MODEL_FORMAT:
        raise ValueError(f"not a homemodel model document (format {doc.get('format')!r})")
    name = doc["name"]
    links: dict[str, bpy.types.Object] = {}
    for link in doc["links"]:
        empty = bpy.data.objects.new(f"{name}:{link['name']}", None)
        empty.empty_display_size = 0.03
        empty[LINK] = link["name"]
        empty[COLLISIONS] = json.dumps(link.get("collisions", []))
        empty[INERTIAL] = json.dumps(link.get("inertial"))
        collection.objects.link(empty)
        links[link["name"]] = empty
        for visual in link.get("visuals", []):
            obj = _mesh_object(f"{name}:{visual['name']}", visual, collection)
            obj.parent = empty
            obj.matrix_basis = matrix_of(visual["link_from_visual"])
    for joint in doc.get("joints", []):
        _set_joint(links[joint["child"]], joint, links[joint["parent"]])
    for grasp in doc.get("grasp_points", []):
        empty = bpy.data.objects.new(f"{name}:grasp:{grasp['name']}", None)
        empty.empty_display_type = "ARROWS"
        empty.empty_display_size = 0.04
        empty.show_name = True
        empty[GRASP] = grasp["name"]
        empty[GRASP_KIND] = grasp.get("kind", "handle")
        collection.objects.link(empty)
        empty.parent = links[grasp["link"]]
        empty.matrix_basis = matrix_of(grasp["link_from_grasp"])
    child_links = {j["child"] for j in doc.get("joints", [])}
    roots = [links[n] for n in links if n not in child_links]
    if len(roots) != 1:
        raise ValueError(f"model {name!r} has {len(roots)} root links; expected one")
    root = roots[0]
    root[MODEL] = json.dumps({k: doc.get(k) for k in ("name", "category", "affordances", "properties")})
    if doc.get("spec") is not None:
        root[SPEC] = json.dumps(doc["spec"])
    if world_from_model is not None:
        root.matrix_world = world_from_model
    return root


def select_only(context, obj: bpy.types.Object) -> None:
    """Make `obj` the one selected, active object."""
    for other in context.selected_objects:
        other.select_set(False)
    obj.select_set(True)
    context.view_layer.objects.active = obj


def owning_link(obj: bpy.types.Object) -> bpy.types.Object | None:
    """The link `obj` belongs to: itself if it is one, else its nearest link ancestor."""
    while obj is not None and LINK not in obj:
        obj = obj.parent
    return obj


def _reparent(obj: bpy.types.Object, parent: bpy.types.Object) -> None:
    """Parent `obj` to `parent` where it stands."""
    world = obj.matrix_world.copy()
    obj.parent = parent
    obj.matrix_parent_inverse = parent.matrix_world.inverted()
    obj.matrix_world = world


def make_model(name: str, category: str, meshes, world_from_model: Matrix, collection) -> bpy.types.Object:
    """A model of one link, "base", at `world_from_model`, owning `meshes`."""
    root = bpy.data.objects.new(f"{name}:base", None)
    root.empty_display_size = 0.05
    collection.objects.link(root)
    root.matrix_world = world_from_model
    root[LINK] = "base"
    root[MODEL] = json.dumps({"name": name, "category": category, "affordances": [], "properties": {}})
    bpy.context.view_layer.update()
    for mesh in meshes:
        _reparent(mesh, root)
    return root


def add_joint(meshes, name: str, kind: str, model_axis: Vector, limits: tuple[float, float], world_point) -> bpy.types.Object:
    """A new link `name` owning `meshes`, joined to the link that owned the first of them at
    `world_point`, moving about or along `model_axis` (in the model's frame)."""
    parent = owning_link(meshes[0])
    link = bpy.data.objects.new(f"{json.loads(model_root(parent)[MODEL])['name']}:{name}", None)
    link.empty_display_size = 0.03
    for collection in parent.users_collection:
        collection.objects.link(link)
    bpy.context.view_layer.update()
    parent_from_world = rigid(parent.matrix_world).inverted()
    # The joint frame keeps the parent's orientation; the axis goes into it.
    parent_from_joint = Matrix.Translation(parent_from_world @ Vector(world_point))
    model_from_parent = rigid(model_root(parent).matrix_world).inverted() @ rigid(parent.matrix_world)
    axis = (model_from_parent.to_3x3().inverted() @ model_axis).normalized()
    _set_joint(link, {"name": f"{name}_joint", "type": kind, "parent_from_joint": parent_from_joint, "axis": axis,
                      "limits": {"lower": limits[0], "upper": limits[1]}}, parent)
    link[LINK] = name
    bpy.context.view_layer.update()
    for mesh in meshes:
        _reparent(mesh, link)
    return link


def rig_imported(objects) -> list[bpy.types.Object]:
    """Rig models that came back through Blender's glTF importer (their properties came back
    from the node extras, their drivers did not); returns their root links."""
    for obj in objects:
        if JOINT in obj:
            # The importer gives the node's local matrix: the origin, moved by the joint.
            obj.matrix_parent_inverse = obj.matrix_parent_inverse @ obj.matrix_basis @ joint_motion(obj).inverted()
            obj.matrix_basis = Matrix.Identity(4)
            rig_joint(obj)
    return [obj for obj in objects if MODEL in obj]


# Reading a model back


def evaluate(view_layer, roots) -> None:
    """Bring the models' world matrices up to their joints' positions, however those were set."""
    for root in roots:
        for joint in joints_of(root):
            joint.update_tag()
    view_layer.update()


def model_root(obj: bpy.types.Object | None) -> bpy.types.Object | None:
    """The root link of the model `obj` belongs to, or None."""
    while obj is not None:
        if MODEL in obj:
            return obj
        obj = obj.parent
    return None


def owned(obj: bpy.types.Object):
    """The objects `obj` owns: its descendants, not passing through another link or model."""
    for child in obj.children:
        if LINK in child or MODEL in child:
            continue
        yield child
        yield from owned(child)


def links_of(root: bpy.types.Object) -> list[bpy.types.Object]:
    """The model's link empties, root first, parents before children."""
    order = [root]
    for obj in order:
        order.extend(c for c in obj.children if LINK in c and MODEL not in c)
    return order


def joints_of(root: bpy.types.Object) -> list[bpy.types.Object]:
    return [obj for obj in links_of(root) if JOINT in obj]


def joint_motion(obj: bpy.types.Object) -> Matrix:
    """How the joint on `obj` at its position moves the child, in the joint frame."""
    axis = Vector(obj[AXIS]).normalized() if Vector(obj[AXIS]).length > 0 else Vector((0.0, 0.0, 1.0))
    q = float(obj.get(POSITION, 0.0))
    if obj[JOINT_TYPE] in ROTATING_JOINT_TYPES:
        return Matrix.Rotation(q, 4, axis)
    if obj[JOINT_TYPE] == "prismatic":
        return Matrix.Translation(axis * q)
    return Matrix.Identity(4)


def _visuals(link: bpy.types.Object, depsgraph) -> list[dict]:
    link_from_world = rigid(link.matrix_world).inverted()
    visuals = []
    for obj in owned(link):
        if obj.type != "MESH":
            continue
        link_from_object = link_from_world @ obj.matrix_world
        link_from_visual = rigid(link_from_object)
        visual_from_object = link_from_visual.inverted() @ link_from_object  # the scale, if any
        mesh = obj.evaluated_get(depsgraph).to_mesh()
        mesh.calc_loop_triangles()
        by_material: dict[int, list] = {}
        for triangle in mesh.loop_triangles:
            by_material.setdefault(triangle.material_index, []).append(triangle)
        for index, triangles in sorted(by_material.items()):
            material = obj.material_slots[index].material if index < len(obj.material_slots) else None
            texture = _texture_path(material) if mesh.uv_layers.active is not None else None
            visual = {
                "name": obj.get("hm_visual", obj.name.split(":")[-1]) + (f"_{index}" if len(by_material) > 1 else ""),
                "material": material.name if material else "default",
                "rgba": list(material.diffuse_color) if material else [0.8, 0.8, 0.8, 1.0],
                "link_from_visual": rows_of(link_from_visual),
            }
            visual.update(_corners(mesh, triangles, visual_from_object, textured=texture is not None))
            if texture is not None:
                visual["texture"] = texture
            visuals.append(visual)
        obj.evaluated_get(depsgraph).to_mesh_clear()
    return visuals


def _corners(mesh: bpy.types.Mesh, triangles, visual_from_object: Matrix, *, textured: bool) -> dict:
    """Vertices, faces and (when `textured`) one UV per vertex of `triangles`. A vertex whose
    face corners carry different UVs (on a texture seam) becomes one vertex per UV."""
    uv_data = mesh.uv_layers.active.data if textured else None
    index: dict[tuple, int] = {}
    vertices, uvs, faces = [], [], []
    for triangle in triangles:
        face = []
        for vertex, loop in zip(triangle.vertices, triangle.loops):
            uv = tuple(round(c, 7) for c in uv_data[loop].uv) if textured else ()
            key = (vertex, uv)
            if key not in index:
                index[key] = len(vertices)
                vertices.append(list(visual_from_object @ mesh.vertices[vertex].co))
                uvs.append(list(uv))
            face.append(index[key])
        faces.append(face)
    return {"vertices": vertices, "faces": faces, **({"uv": uvs} if textured else {})}


def model_document(root: bpy.types.Object, depsgraph) -> dict:
    """The model document of the model whose root link is `root`, as the scene shows it now."""
    info = json.loads(root[MODEL])
    links, joints, grasps = [], [], []
    for link in links_of(root):
        collisions = json.loads(link[COLLISIONS]) if COLLISIONS in link else None
        visuals = _visuals(link, depsgraph)
        links.append(
            {
                "name": link[LINK],
                "visuals": visuals,
                "collisions": collisions,  # None: the toolkit wraps the visuals in a convex hull
                # A link made by hand has neither: the toolkit derives them from its meshes.
                "inertial": json.loads(link[INERTIAL]) if INERTIAL in link else FROM_MESHES,
            }
        )
        if JOINT in link:
            parent = link.parent
            parent_from_joint = rigid(parent.matrix_world).inverted() @ rigid(link.matrix_world) @ joint_motion(link).inverted()
            joint = {
                "name": link[JOINT],
                "type": link[JOINT_TYPE],
                "parent": parent[LINK],
                "child": link[LINK],
                "parent_from_joint": rows_of(parent_from_joint),
                "axis": list(Vector(link[AXIS]).normalized()),
                "states": json.loads(link.get(STATES, "[]")),
                "position": float(link.get(POSITION, 0.0)),
            }
            if LOWER in link:
                defaults = {EFFORT: 10.0, VELOCITY: 1.0}
                joint["limits"] = {k: float(link.get(p, defaults.get(p, 0.0))) for k, p in (("lower", LOWER), ("upper", UPPER), ("effort", EFFORT), ("velocity", VELOCITY))}
            if DYNAMICS in link:
                joint["dynamics"] = json.loads(link[DYNAMICS])
            joints.append(joint)
        for obj in owned(link):
            if GRASP in obj:
                link_from_grasp = rigid(link.matrix_world).inverted() @ rigid(obj.matrix_world)
                grasps.append({"name": obj[GRASP], "link": link[LINK], "kind": obj.get(GRASP_KIND, "handle"), "link_from_grasp": rows_of(link_from_grasp)})
    return {
        "format": MODEL_FORMAT,
        **info,
        "spec": json.loads(root[SPEC]) if SPEC in root else None,
        "links": links,
        "joints": joints,
        "grasp_points": grasps,
    }


def model_objects(root: bpy.types.Object) -> list[bpy.types.Object]:
    """Every object of the model: its links and what they own."""
    objects = []
    for link in links_of(root):
        objects.append(link)
        objects.extend(owned(link))
    return objects


def remove_model(root: bpy.types.Object) -> None:
    for obj in model_objects(root):
        bpy.data.objects.remove(obj, do_unlink=True)
