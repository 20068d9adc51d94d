"""The rendered photo set with ground truth of test_photogrammetry_pipeline: 36 views of the
vase on three rings, their file names shuffled, rendered once with the toolkit's ray caster
(photogrammetry/ray_rendering.py: 24 CPU-s against 100 with Blender's Cycles at 4 samples,
measured side by side at a load of 15; docs/photogrammetry.md has the figures of both sets) and cached in build/test-cache/ until the rendering code changes. A lock
keeps two pytest runs from rendering into the folder at once."""

from __future__ import annotations

from fixture_cache import CACHE_ROOT, locked

NAME = "photogrammetry_rings"


def rendered_photo_set():  # noqa: ANN201 (a heavy import: photogrammetry.synthetic_scene)
    from photogrammetry.synthetic_scene import SceneOptions, render_scene

    with locked(NAME):
        return render_scene(
            CACHE_ROOT / NAME, SceneOptions(n_views=36, rings=3, shuffled=True, width_px=640, height_px=480, renderer="rays")
        )
