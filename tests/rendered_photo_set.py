"""The rendered photo set with ground truth of test_photogrammetry_pipeline: 36 views of the
vase on three rings, their file names shuffled, rendered once with the toolkit's ray caster
(photogrammetry/ray_rendering.py: 24 CPU-s against 100 with Blender's Cycles at 4 samples,
measured side by side at a load of 15; docs/photogrammetry.md has the figures of both sets) and
kept in the fixture cache (tests/fixture_cache.py) per content of the options and of the code
that renders it (the photogrammetry package and the layers below, homemodel.geometry's ray
caster among them), so two checkouts of different code never render into one folder."""

from __future__ import annotations

from fixture_cache import cached_folder, content_key

NAME = "photogrammetry_rings"


def rendered_photo_set():  # noqa: ANN201 (a heavy import: photogrammetry.synthetic_scene)
    from photogrammetry.synthetic_scene import SceneOptions, render_scene

    options = SceneOptions(n_views=36, rings=3, shuffled=True, width_px=640, height_px=480, renderer="rays")
    key = content_key(packages=("photogrammetry",), settings=repr(options))
    folder = cached_folder(NAME, key, lambda folder: render_scene(folder, options))
    return render_scene(folder, options)  # reads the set rendered there
