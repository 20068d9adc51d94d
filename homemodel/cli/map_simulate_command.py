"""`homemodel map simulate-view MAP.xml --camera camera.yaml --out OBS_DIR`: an observation of
the home rendered from the map's own models, with a structured-light sensor's noise and the
truth (`truth.json`), for testing perception (`homemodel map observe`) without a robot."""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING

import typer

from homemodel.cli.errors import exit_on_error
from homemodel.cli.map_commands import MAP_ARGUMENT, map_app
from homemodel.cli.option_fields import field_option, from_options

if TYPE_CHECKING:
    from tracking.simulate_view import SmallObjectMove

VIEW = "tracking.simulate_view:ViewOptions"
LOOK_AT = "tracking.simulate_view:ViewSimulator.camera_looking_at"
_MOVE = re.compile(r"^(?P<object>[^=:]+)=(?:(?P<parent>[^=:]+):)?(?P<numbers>[^=:]+)$")


def parse_joints(items: list[str]) -> dict[str, dict[str, str]]:
    """`OBJ/JOINT=VALUE` items as {object: {joint: value}}; VALUE is rad or m, or a named state."""
    from homemodel.core.errors import InputError

    joints: dict[str, dict[str, str]] = {}
    for item in items:
        key, sep, value = item.partition("=")
        object_id, slash, joint = key.partition("/")
        if not (sep and slash and object_id and joint and value):
            raise InputError(f"--joint {item!r}: expected OBJECT/JOINT=VALUE (rad or m, or a state name such as open)")
        joints.setdefault(object_id, {})[joint] = value
    return joints


def parse_move(item: str) -> SmallObjectMove:
    """`OBJ=x,y,yaw`, `OBJ=x,y,z,yaw`, `OBJ=PARENT:x,y,yaw` or `OBJ=PARENT:x,y,z,yaw` (m, rad)."""
    from homemodel.core.errors import InputError
    from tracking.simulate_view import SmallObjectMove

    match = _MOVE.match(item)
    try:
        numbers = [float(v) for v in match["numbers"].split(",")] if match else []
    except ValueError:
        numbers = []
    if len(numbers) not in (3, 4):
        raise InputError(f"--move {item!r}: expected OBJECT=[PARENT:]x,y,yaw or OBJECT=[PARENT:]x,y,z,yaw (m, rad)")
    x, y, *z, yaw = numbers
    return SmallObjectMove(
        object_id=match["object"], parent_id=match["parent"], x_m=x, y_m=y, z_m=z[0] if z else None, yaw_rad=yaw
    )


def parse_occlusions(items: list[str]) -> dict[str, float]:
    from homemodel.core.errors import InputError

    fractions = {}
    for item in items:
        object_id, sep, value = item.partition("=")
        try:
            fractions[object_id] = float(value)
        except ValueError:
            sep = ""
        if not (sep and object_id):
            raise InputError(f"--occlude {item!r}: expected OBJECT=FRACTION, e.g. fridge_1=0.3")
    return fractions


@map_app.command("simulate-view")
@from_options
def simulate_view(
    map_path: Path = MAP_ARGUMENT,
    camera_path: Path = typer.Option(..., "--camera", help="camera.yaml: width, height, fx, fy, cx, cy, depth_scale_m, and map_from_camera unless --look-at is given"),
    out: Path = typer.Option(..., "--out", help="observation folder to write: depth.png, color.png, camera.yaml, truth.json"),
    joint: list[str] = typer.Option([], "--joint", help="OBJECT/JOINT=VALUE: a joint's true position (rad or m) or named state, e.g. fridge_1/door_0_hinge=0.8; repeatable"),
    move: list[str] = typer.Option([], "--move", help="OBJECT=[PARENT:]x,y[,z],yaw: a small object moved in its parent's frame, or onto PARENT (re-parented; without z it stands on PARENT's top); repeatable"),
    occlude: list[str] = typer.Option([], "--occlude", help="OBJECT=FRACTION: a box half-way to the camera hides that fraction of the object, from its left; repeatable"),
    noise: str = field_option(f"{VIEW}.noise.model", "--noise", help="kinect (structured-light noise, 1 mm steps, grazing and random dropouts) or none"),
    seed: int = field_option(f"{VIEW}.noise.seed", help="seed of the sensor noise"),
    look_at: str | None = typer.Option(None, "--look-at", help="place the camera in front of this object (its +x side), looking at its centre"),
    distance_m: float = field_option(f"{LOOK_AT}.distance_m", help="with --look-at: horizontal distance from the object's centre"),
    height_m: float = field_option(f"{LOOK_AT}.height_m", help="with --look-at: camera height above the floor"),
    bearing_deg: float = field_option(f"{LOOK_AT}.bearing_deg", help="with --look-at: turn the camera about the object, toward its +y"),
    force: bool = typer.Option(False, "--force", help="replace a non-empty output folder"),
) -> None:
    """Render a depth camera's view of the home, to test `map observe` without a robot.

    The map's models at its joint states and poses (or those given), a floor and walls, with sensor noise.
    truth.json holds the true joint states and poses, and what each part shows."""
    import time

    import numpy as np

    from homemodel.cli.progress import make_console, stage_bars
    from homemodel.core.atomic import prepare_out_dir
    from homemodel.core.errors import InputError
    from homemodel.exchange.home_scene import model_path
    from tracking.observation_files import load_observation_camera
    from tracking.sensor_noise import SensorNoise
    from tracking.simulate_view import ViewOptions, ViewSimulator, write_view

    start = time.perf_counter()
    with exit_on_error():
        options = ViewOptions(
            joint_positions=parse_joints(joint),
            moves=[parse_move(item) for item in move],
            occlude=parse_occlusions(occlude),
            noise=SensorNoise(model=noise, seed=seed),
        )
        options.check()
        camera, map_from_camera = load_observation_camera(camera_path, need_pose=False)
        if map_from_camera is None and look_at is None:
            raise InputError(f"{camera_path}: no map_from_camera (the camera's pose in the map): add it, or give --look-at OBJECT")
        simulator = ViewSimulator.load(map_path)
        # The map's model folders are inputs too: `--out build/kitchen/models --force` deleted them.
        model_dirs = {model_path(map_path, o.node).parent for o in simulator.scene.objects.values()}
        inputs = [map_path, camera_path, *sorted(model_dirs)]
        prepare_out_dir(out, force=force, inputs=inputs)  # before the render
        if look_at is not None:
            map_from_camera = simulator.camera_looking_at(
                look_at, distance_m=distance_m, height_m=height_m, bearing_deg=bearing_deg
            )
        with stage_bars(make_console()) as progress:
            view = simulator.render(camera, map_from_camera, options, progress=progress)
        write_view(view, out, force=force, inputs=inputs)
    depth = view.observation.depth_m
    objects = sorted({p["object"] for p in view.observation.truth["parts"] if p["pixels"] > 0})
    typer.echo(
        f"{out}: {camera.width}x{camera.height}, {int(np.count_nonzero(depth))} depth readings, "
        f"{len(objects)} object{'' if len(objects) == 1 else 's'} in view ({', '.join(objects) or 'none'}), "
        f"{time.perf_counter() - start:.2f} s"
    )
