"""Benchmark: `map observe` on simulated views of the demo kitchen (640x480, Kinect-like
noise), the map it is given 2 cm and 2 degrees off the truth for every large object, beside
the obvious baseline run on the same views: one rigid ICP of each whole model at its map
joint states (Open3D point-to-plane, the same Tukey kernel), which can refine the pose but
never a door.

    .venv/bin/python benchmarks/bench_tracking.py [--views 4] [--seed 0] [--unlike-mm 5] [--scale 1.1]

`--unlike-mm` renders the views from furniture that is not the map's models: each link
larger or smaller and shifted by millimetres (`tracking.simulate_view.unlike_their_models`),
as the real pieces differ from what an installer measured. `--scale` makes the furniture other
pieces than the kitchen's: each large object's model (its links and joint origins, about its
own frame) that many times its size, in the map and in the views alike, the small objects kept
on their surfaces; the map is then given to `observe` loaded (its reading is not timed).

Each articulated object (cupboard, fridge, oven) is seen from 1.2 to 2.5 m at random joint
states, once clear and once with a box covering 30 % of it; the table is seen with its cups
moved about and the red cup put on the cupboard. Errors count the parts at least half
visible: a joint's links' pixels seen over their pixels with nothing in front and the image
as large as they are (the simulator's truth), so a part the image's edge cuts in half is
half visible. Each miss is printed with its distance, visibility (true and as the fitter
estimates it), residual and its object's pose error. A joint under half visible that the
command writes more than the target off is counted apart: it should be "not seen" or
"partly seen" instead. Times are wall-clock seconds on this machine, whatever else runs on
it; the CPU seconds are printed beside them.
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

ROOT = Path(__file__).resolve().parents[1]
ARTICULATED = ("cupboard_1", "fridge_1", "oven_1")
CAMERA = dict(width=640, height=480, fx=525.0, fy=525.0, cx=319.5, cy=239.5)
ISSUE_RANGE_M = (1.2, 2.5)  # the distances the issue's accuracy targets hold at


def kitchen() -> Path:
    out = ROOT / "build" / "bench_tracking" / "kitchen"
    if not (out / "map.xml").is_file():
        subprocess.run([sys.executable, "-m", "homemodel", "build", str(ROOT / "examples" / "kitchen"), "--out", str(out),
                        "--force"], check=True)
    return out / "map.xml"


def prior_map(map_path: Path, folder: Path, rng: np.random.Generator) -> Path:
    """The map with each large object 2 cm (in a random direction) and 2 degrees (either way) off."""
    from homemodel.core.transforms import transform_from_xyz_rpy
    from homemodel.exchange.map_xml import load_map, save_map
    from tracking.observe import rebase_model_refs

    smap = load_map(map_path)
    for room in smap.apartment.rooms:
        for large in room.objects:
            angle = rng.uniform(0, 2 * np.pi)
            off = transform_from_xyz_rpy((0.02 * np.cos(angle), 0.02 * np.sin(angle), 0.0),
                                         (0.0, 0.0, np.radians(2.0) * rng.choice([-1, 1])))
            large.world_from_object = large.world_from_object.from_matrix(large.world_from_object.matrix() @ off)
    out = folder / "prior.xml"
    rebase_model_refs(smap, map_path, out)
    save_map(smap, out)
    return out


def scaled_furniture(scene, factor: float):
    """`scene` (a `HomeScene`, changed and returned) with each large object's model `factor`
    times its size about its own frame, links and joint origins, and each small object's place
    on its parent moved with the parent's surfaces."""
    import dataclasses

    from semantic_map.nodes import Pose

    large = {object_id for object_id, obj in scene.objects.items() if not obj.is_small}
    for object_id in large:
        obj = scene.objects[object_id]
        obj.model = copy.deepcopy(obj.model)
        for joint in obj.model.joints:
            joint.parent_from_joint[:3, 3] *= factor
    scene.parts = [dataclasses.replace(p, vertices_link=p.vertices_link * factor) if p.object_id in large else p
                   for p in scene.parts]
    for obj in scene.objects.values():
        if obj.is_small and obj.node.parent in large:
            parent_from_object = obj.node.parent_from_object.matrix()
            parent_from_object[:3, 3] *= factor
            obj.node.parent_from_object = Pose.from_matrix(parent_from_object)
    return scene


def rigid_icp_baseline(prior, observation, options) -> dict[str, np.ndarray]:
    """Each large object in view refined by one rigid ICP of its whole model at the map's joint states."""
    from tracking.fit_pose import refine_pose
    from tracking.fit_state import FitState
    from tracking.fit_view import FitView
    from tracking.scene import HomeScene

    observe_module = sys.modules["tracking.observe"]
    state = FitState.start(prior if isinstance(prior, HomeScene) else HomeScene.load(prior))
    view = FitView.from_depth(observation.camera, observation.map_from_camera, observation.depth_m,
                              factor=options.fine_factor, min_tolerance_m=options.min_tolerance_m,
                              tolerance_sigmas=options.tolerance_sigmas)
    coarse = FitView.from_depth(observation.camera, observation.map_from_camera, observation.depth_m,
                                factor=options.coarse_factor, min_tolerance_m=options.min_tolerance_m,
                                tolerance_sigmas=options.tolerance_sigmas)
    poses = {}
    for object_id in observe_module._objects_in_view(state, coarse, options):
        background = state.background_depth(view, object_id)
        kernel = observe_module._kernel_m(state, view, object_id, options)
        refine_pose(state, view, object_id, state.object_parts(object_id), background, gates_m=options.pose_gates_m,
                    kernel_m=kernel, min_points=options.min_pose_points, planar=True)
        poses[object_id] = state.map_from_objects[object_id]
    return poses


def scenarios(rng: np.random.Generator, views: int):
    """(name, look-at object, distance m, bearing deg, ViewOptions kwargs) of every view."""
    from tracking.simulate_view import SmallObjectMove

    for object_id in ARTICULATED:
        for k in range(views):
            distance = float(np.interp(k, [0, max(views - 1, 1)], [1.2, 2.5]))
            bearing = float(rng.uniform(-25, 25))
            joints = {}
            for name, high in {"cupboard_1": {"door_0_hinge": 1.6, "door_1_hinge": 1.6, "drawer_0_slide": 0.3},
                               "fridge_1": {"door_0_hinge": 1.5, "drawer_0_slide": 0.35},
                               "oven_1": {"door_0_hinge": 1.4, "drawer_0_slide": 0.3}}[object_id].items():
                joints[name] = float(rng.uniform(0, high)) if rng.random() < 0.75 else 0.0
            for occluded in (False, True):
                kwargs = {"joint_positions": {object_id: joints}}
                if occluded:
                    kwargs["occlude"] = {object_id: 0.3}
                yield (f"{object_id} {distance:.1f} m{' occluded' if occluded else ''}", object_id, distance, bearing, kwargs)
    for k in range(views):
        moves = [
            SmallObjectMove(object_id="blue_cup", x_m=float(rng.uniform(-0.4, 0.0)), y_m=float(rng.uniform(0.0, 0.3)),
                            yaw_rad=float(rng.uniform(-3, 3))),
            SmallObjectMove(object_id="sugar_container", x_m=float(rng.uniform(-0.35, -0.15)),
                            y_m=float(rng.uniform(-0.35, -0.2)), yaw_rad=0.0),
        ]
        if k % 2 == 0:
            moves.append(SmallObjectMove(object_id="red_cup", x_m=0.0, y_m=float(rng.uniform(-0.3, 0.3)),
                                         yaw_rad=float(rng.uniform(-3, 3)), parent_id="cupboard_1"))
        yield (f"table {k}", None, 0.0, 0.0, {"moves": moves})


def table_camera() -> np.ndarray:
    from homemodel.core.transforms import world_from_camera_looking_at

    return world_from_camera_looking_at(np.array([2.7, 3.3, 1.6]), np.array([1.1, 2.3, 0.7]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--views", type=int, default=4, help="distances per object (and table views)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--unlike-mm", type=float, default=0.0,
                        help="render the views from furniture this far off the map's models (each link's size and place)")
    parser.add_argument("--scale", type=float, default=1.0,
                        help="other furniture: each large object's model this many times its size, in the map and the views")
    args = parser.parse_args()
    if not 0.5 <= args.scale <= 2.0:
        parser.error(f"--scale {args.scale:g}: give a factor from 0.5 to 2")

    from homemodel.geometry.camera import Camera
    from tracking import ObserveOptions, observe
    from tracking.sensor_noise import SensorNoise
    from tracking.scene import HomeScene
    from tracking.simulate_view import ViewOptions, ViewSimulator, unlike_their_models

    map_path = kitchen()
    rng = np.random.default_rng(args.seed)
    simulator = ViewSimulator.load(map_path)
    if args.scale != 1.0:
        simulator = ViewSimulator(scaled_furniture(simulator.scene, args.scale))
    if args.unlike_mm > 0:
        simulator = ViewSimulator(unlike_their_models(simulator.scene, off_m=args.unlike_mm / 1000, seed=args.seed))
    camera = Camera(**CAMERA)
    options = ObserveOptions()
    rows = {k: {"fit": [], "base": []} for k in ("door", "drawer", "pose_m", "pose_deg", "small", "small_in_range")}
    worse_poses, wrong_partly = [0, 0], [0, 0]  # (count, of how many): poses written worse than the map's; joints under half visible
    wrong_found = [0, 0]  # small objects written found more than 1 cm from where they are, or on another parent
    worse_surfaces = 0  # poses written whose footprint's corners lie > 2 mm farther off than the map's
    outcomes = {"occluded": {"door": [], "drawer": []}}
    seen = {"door": 0, "drawer": 0, "small": 0}
    times, cpu_times, per_object, per_object_cpu, baseline_cpu = [], [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        prior = prior_map(map_path, folder, rng)
        prior_scene = scaled_furniture(HomeScene.load(prior), args.scale) if args.scale != 1.0 else None
        footprints = {object_id: obj.model.world_mesh().bounds[:, :2]
                      for object_id, obj in (prior_scene or simulator.scene).objects.items()}
        for index, (name, object_id, distance, bearing, kwargs) in enumerate(scenarios(rng, args.views)):
            if object_id is None:
                map_from_camera = table_camera()
            else:
                map_from_camera = simulator.camera_looking_at(object_id, distance_m=distance, height_m=1.4, bearing_deg=bearing)
            view = simulator.render(camera, map_from_camera, ViewOptions(noise=SensorNoise(seed=index), **kwargs))
            truth = view.observation.truth
            # `observe` writes what it saw into the scene's map: each view gets its own copy.
            given = prior if prior_scene is None else copy.deepcopy(prior_scene)
            start, cpu = time.perf_counter(), time.process_time()
            result = observe(given, view.observation, options)
            times.append(time.perf_counter() - start)
            cpu_times.append(time.process_time() - cpu)
            per_object.extend(o.seconds for o in result.report.objects)
            per_object_cpu.append(cpu_times[-1] / max(len(result.report.objects), 1))
            cpu = time.process_time()
            baseline = rigid_icp_baseline(prior if prior_scene is None else copy.deepcopy(prior_scene), view.observation, options)
            baseline_cpu.append(time.process_time() - cpu)
            visible = _joint_visibility(truth)
            written = {s.id: s for obj in result.report.objects for s in obj.small_objects if s.status == "found"}
            for small in written.values():
                true_small = truth["objects"][small.id]
                off_mm = np.linalg.norm(small.map_from_object[:3, 3] - np.array(true_small["map_from_object"])[:3, 3]) * 1000
                wrong_found[1] += 1
                if off_mm > 10.0 or small.parent != true_small["parent"]:
                    wrong_found[0] += 1
                    print(f"  small written wrong: {small.id} on {small.parent} (truth on {true_small['parent']}), {off_mm:.0f} mm off")
            for obj in result.report.objects:
                true_pose = np.array(truth["objects"][obj.id]["map_from_object"])
                for key, estimate in (("fit", obj.map_from_object), ("base", baseline.get(obj.id, obj.previous_map_from_object))):
                    error = np.linalg.inv(true_pose) @ estimate
                    rows["pose_m"][key].append(float(np.linalg.norm(error[:2, 3])))
                    rows["pose_deg"][key].append(abs(float(np.degrees(np.arctan2(error[1, 0], error[0, 0])))))
                true_prior = np.linalg.inv(true_pose) @ obj.previous_map_from_object
                pose_mm, prior_mm = rows["pose_m"]["fit"][-1] * 1000, float(np.linalg.norm(true_prior[:2, 3])) * 1000
                if obj.pose_refined:
                    worse_poses[0] += pose_mm > prior_mm + 2.0
                    worse_poses[1] += 1
                    corners_off = [_corners_off_mm(footprints[obj.id], pose, true_pose)
                                   for pose in (obj.map_from_object, obj.previous_map_from_object)]
                    worse_surfaces += corners_off[0] > corners_off[1] + 2.0
                if pose_mm > 10:
                    print(f"  pose miss: {obj.id} {pose_mm:.0f} mm, the map's {prior_mm:.0f} "
                          f"({'refined' if obj.pose_refined else 'kept'}: {obj.pose_note})")
                for joint in obj.joints:
                    if joint.name.startswith("knob"):
                        continue
                    kind = "drawer" if joint.type == "prismatic" else "door"
                    scale = 1000.0 if kind == "drawer" else float(np.degrees(1.0))
                    limit = 5.0 if kind == "drawer" else 2.0
                    true_value = truth["joints"][obj.id][joint.name]
                    if visible.get((obj.id, joint.name), 0.0) < 0.5:
                        if joint.status == "fitted":
                            wrong_partly[0] += abs(joint.position - true_value) * scale > limit
                            wrong_partly[1] += 1
                        continue
                    fit_error = abs(joint.position - true_value) * scale if joint.status == "fitted" else float("inf")
                    rows[kind]["fit"].append(fit_error)
                    rows[kind]["base"].append(abs(joint.previous - true_value) * scale)
                    seen[kind] += 1
                    if fit_error > limit:
                        print(f"  miss: {obj.id}/{joint.name} {joint.status} {fit_error:.1f} (truth {true_value:.3f}, "
                              f"{distance:.1f} m, visible {visible[(obj.id, joint.name)]:.2f}, estimated "
                              f"{joint.visible_fraction:.2f}, residual {joint.residual_m * 1000:.1f} mm, pose {pose_mm:.0f} mm "
                              f"{'refined' if obj.pose_refined else 'kept'})")
                    if "occluded" in name:
                        outcomes["occluded"][kind].append(fit_error)
                for small in obj.small_objects:
                    body = [p["visible_fraction"] for p in truth["parts"] if p["object"] == small.id and not p["joint"]]
                    if small.previous_parent != obj.id or not body or body[0] < 0.5:
                        continue
                    true_xyz = np.array(truth["objects"][small.id]["map_from_object"])[:3, 3]
                    found = small.status == "found" and small.parent == truth["objects"][small.id]["parent"]
                    error = np.linalg.norm(small.map_from_object[:3, 3] - true_xyz) * 1000 if found else float("inf")
                    rows["small"]["fit"].append(float(error))
                    seen["small"] += 1
                    # The issue's targets hold 1.2-2.5 m from the camera; the cupboard's views at
                    # 2.5 m see its pill box 2.74 m away.
                    away = float(np.linalg.norm(true_xyz - map_from_camera[:3, 3]))
                    if ISSUE_RANGE_M[0] <= away <= ISSUE_RANGE_M[1]:
                        rows["small_in_range"]["fit"].append(float(error))
                    if error > 10.0:
                        print(f"  small miss: {small.id} {small.status} {error:.1f} mm, {away:.2f} m from the camera, "
                              f"visible {body[0]:.2f}")
            print(f"{name:<28} {times[-1]:5.2f} s  {len(result.report.objects)} objects in view", flush=True)
    title = f"views rendered from furniture {args.unlike_mm:g} mm off the models, " if args.unlike_mm else ""
    title += f"furniture {args.scale:g} times the kitchen's, " if args.scale != 1.0 else ""
    _print(rows, outcomes, seen, times, cpu_times, per_object, per_object_cpu, baseline_cpu, worse_poses, wrong_partly,
           wrong_found, worse_surfaces, title)


def _corners_off_mm(footprint: np.ndarray, estimate: np.ndarray, truth: np.ndarray) -> float:
    """The mean distance (x, y) of the four corners of an object's footprint (its model's
    (2, 2) low and high x, y) at `estimate` from where they are: where its surfaces are, which
    its origin alone does not say once the turn changes too."""
    corners = np.array([[x, y, 0.0, 1.0] for x in footprint[:, 0] for y in footprint[:, 1]])
    return float(np.linalg.norm((corners @ estimate.T - corners @ truth.T)[:, :2], axis=1).mean() * 1000)


def _joint_visibility(truth: dict) -> dict[tuple[str, str], float]:
    """{(object, joint): visible fraction of the links the joint moves, together}."""
    seen: dict[tuple[str, str], list[int]] = {}
    for part in truth["parts"]:
        if part["joint"]:
            counts = seen.setdefault((part["object"], part["joint"]), [0, 0])
            counts[0] += part["pixels"]
            counts[1] += part["pixels_unoccluded"]
    return {key: s / alone for key, (s, alone) in seen.items() if alone}


def _within(values: list[float], limit: float) -> str:
    values = np.asarray(values)
    return f"{np.mean(values <= limit):.0%} (median {np.median(values):.2f}, max {np.max(values):.2f})" if len(values) else "-"


def _print(rows, outcomes, seen, times, cpu_times, per_object, per_object_cpu, baseline_cpu, worse_poses, wrong_partly,
           wrong_found, worse_surfaces, title) -> None:
    table = Table(title=f"map observe on simulated kitchen views ({title}prior 2 cm, 2 deg off)")
    table.add_column("figure")
    table.add_column("articulated fit (observe)", justify="right")
    table.add_column("rigid ICP at map states", justify="right")
    table.add_column("target", justify="right")
    table.add_row(f"doors and flaps within 2 deg ({seen['door']} parts)", _within(rows["door"]["fit"], 2.0),
                  _within(rows["door"]["base"], 2.0), "all")
    table.add_row(f"drawers within 5 mm ({seen['drawer']} parts)", _within(rows["drawer"]["fit"], 5.0),
                  _within(rows["drawer"]["base"], 5.0), "all")
    table.add_row("  with a box over 30 %: doors within 2 deg", _within(outcomes["occluded"]["door"], 2.0), "", "all")
    table.add_row("  with a box over 30 %: drawers within 5 mm", _within(outcomes["occluded"]["drawer"], 5.0), "", "all")
    table.add_row(f"small objects within 1 cm ({seen['small']} seen)", _within(rows["small"]["fit"], 10.0), "not tracked", "")
    table.add_row(f"  of them {ISSUE_RANGE_M[0]:g}-{ISSUE_RANGE_M[1]:g} m from the camera ({len(rows['small_in_range']['fit'])})",
                  _within(rows["small_in_range"]["fit"], 10.0), "not tracked", "all")
    table.add_row("small objects written found > 1 cm off or on another parent", f"{wrong_found[0]} of {wrong_found[1]} found",
                  "not tracked", "0")
    table.add_row("large objects' pose within 1 cm (x, y)", _within([v * 1000 for v in rows["pose_m"]["fit"]], 10.0),
                  _within([v * 1000 for v in rows["pose_m"]["base"]], 10.0), "")
    table.add_row("large objects' yaw within 0.5 deg", _within(rows["pose_deg"]["fit"], 0.5), _within(rows["pose_deg"]["base"], 0.5), "")
    table.add_row("poses written > 2 mm worse than the map's", f"{worse_poses[0]} of {worse_poses[1]} written", "", "0")
    table.add_row("poses written with the footprint's corners > 2 mm farther off", f"{worse_surfaces} of {worse_poses[1]} written", "", "0")
    table.add_row("joints under half visible written off target", f"{wrong_partly[0]} of {wrong_partly[1]} written", "", "0")
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    table.add_row(f"seconds per observation (wall; load average {load} on {os.cpu_count()} cores)",
                  f"median {np.median(times):.2f}, max {np.max(times):.2f}", "", "< 2")
    table.add_row("CPU seconds per observation", f"median {np.median(cpu_times):.2f}, max {np.max(cpu_times):.2f}",
                  f"median {np.median(baseline_cpu):.2f}, max {np.max(baseline_cpu):.2f}", "")
    table.add_row("seconds per object in view (wall)", f"median {np.median(per_object):.2f}, max {np.max(per_object):.2f}", "", "< 0.5")
    table.add_row("CPU seconds per object in view (observation / objects)",
                  f"median {np.median(per_object_cpu):.2f}, max {np.max(per_object_cpu):.2f}", "", "")
    Console(width=150).print(table)
    print(json.dumps({"times_s": [round(t, 3) for t in times]}))


if __name__ == "__main__":
    main()
