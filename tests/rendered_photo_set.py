"""The rendered photo set with ground truth that the photogrammetry tests share: 36 views of
the vase on three rings, their file names shuffled, rendered once with Blender (the longest
part of those tests) and cached in build/test-cache/ until the rendering code changes."""

from __future__ import annotations

from pathlib import Path

CACHE = Path(__file__).resolve().parents[1] / "build" / "test-cache" / "photogrammetry_rings"


def rendered_photo_set():  # noqa: ANN201 (photogrammetry.synthetic_scene imports Blender's helpers)
    from photogrammetry.synthetic_scene import SceneOptions, render_scene

    return render_scene(
        CACHE, SceneOptions(n_views=36, rings=3, shuffled=True, width_px=640, height_px=480, samples=4)
    )
