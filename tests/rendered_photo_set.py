"""The rendered photo set with ground truth of test_photogrammetry_pipeline: 30 views of the
vase on three rings of 10, their file names shuffled, rendered once with the toolkit's ray caster
(photogrammetry/ray_rendering.py: 36 views took 24 CPU-s against 100 with Blender's Cycles at 4
samples, measured side by side at a load of 15; docs/photogrammetry.md has the figures of both
sets) and
kept in the fixture cache (tests/fixture_cache.py) per content of the options and of the code
that renders it (the photogrammetry package and the layers below, homemodel.geometry's ray
caster among them), so two checkouts of different code never render into one folder.

30 views, not 36: the render and the command on it 12.1 + 33.8 CPU-s, every figure the tests
check within its bound with about the margin of 36 (cameras 2.4 mm off at most against 4 mm,
scale 0.02 %, height +0.57 %, surface 0.24 % of the size, watertight, texture r 0.68; baked at
the true cameras 86 % seen, r 0.758). 24 views (8 a ring) left a hole in the mesh's side
(surface 1.35 % against 1 %); 36 views at 512 x 384 px put a camera 3.8 mm off.
"""

from __future__ import annotations

from fixture_cache import cached_folder, content_key

NAME = "photogrammetry_rings"
VIEWS = 30


def rendered_photo_set():  # noqa: ANN201 (a heavy import: photogrammetry.synthetic_scene)
    from photogrammetry.synthetic_scene import SceneOptions, render_scene

    options = SceneOptions(n_views=VIEWS, rings=3, shuffled=True, width_px=640, height_px=480, renderer="rays")
    key = content_key(packages=("photogrammetry",), settings=repr(options))
    folder = cached_folder(NAME, key, lambda folder: render_scene(folder, options))
    return render_scene(folder, options)  # reads the set rendered there
