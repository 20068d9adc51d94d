"""Render an exported MJCF scene with MuJoCo's offscreen renderer (EGL, no display needed).

    MUJOCO_GL=egl python tools/mujoco_picture.py build/kitchen_mjcf/scene.xml docs/images/kitchen_mujoco.png \
        --set fridge_1__door_0_hinge=1.3 --set oven_1__door_0_hinge=1.2

Joints given with --set are moved there, then the scene is simulated for one second, so the
picture shows where things come to rest, not only where they were put.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")


def main() -> None:
    import mujoco
    from PIL import Image

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", type=Path)
    parser.add_argument("png", type=Path)
    parser.add_argument("--set", action="append", default=[], metavar="JOINT=POSITION")
    parser.add_argument("--lookat", type=float, nargs=3, default=(1.5, 3.2, 0.5))
    parser.add_argument("--distance", type=float, default=4.2)
    parser.add_argument("--azimuth", type=float, default=125.0)
    parser.add_argument("--elevation", type=float, default=-30.0)
    args = parser.parse_args()

    model = mujoco.MjModel.from_xml_path(str(args.scene))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("initial").id)
    for item in args.set:
        joint, _, value = item.partition("=")
        data.qpos[model.joint(joint).qposadr[0]] = float(value)
    for _ in range(int(1.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
    camera = mujoco.MjvCamera()
    camera.lookat[:], camera.distance = args.lookat, args.distance
    camera.azimuth, camera.elevation = args.azimuth, args.elevation
    options = mujoco.MjvOption()
    options.geomgroup[:] = 0
    options.geomgroup[0] = options.geomgroup[2] = 1  # floor and walls, visuals; not the colliders
    renderer = mujoco.Renderer(model, 720, 960)
    renderer.update_scene(data, camera, options)
    args.png.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(renderer.render()).save(args.png)


if __name__ == "__main__":
    main()
