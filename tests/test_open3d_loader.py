"""Open3D through `load_open3d`: without the dash/plotly viewer at import, with it when called."""

import subprocess
import sys

import numpy as np

from homemodel.geometry.open3d_loader import load_open3d

_IMPORTED_AFTER_LOAD = "import sys; from homemodel.geometry.open3d_loader import load_open3d; load_open3d(); print(sorted(m for m in ('dash', 'plotly', 'flask') if m in sys.modules))"  # fmt: skip


def test_loading_open3d_imports_no_viewer_libraries() -> None:
    out = subprocess.run([sys.executable, "-c", _IMPORTED_AFTER_LOAD], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_the_viewer_functions_still_work_when_called() -> None:
    o3d = load_open3d()
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.random.default_rng(0).random((50, 3))))
    figure = o3d.visualization.get_plotly_fig([cloud])
    assert type(figure).__module__.startswith("plotly")
    assert len(figure.data) == 1 and len(figure.data[0].x) == 50
