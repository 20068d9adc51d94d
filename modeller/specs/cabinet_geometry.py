"""Where a cabinet's parts lie, worked out from its spec (`modeller.specs.cabinets`): shelf
spans, drawer boxes, door bins. The feasibility rules check them, and the builders place
the parts by them, so both agree on one geometry.

Model frame as in `modeller.specs.common`: the body's front plane at x = depth_m / 2, its
left edge (seen from in front) at y = -width_m / 2.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from modeller.specs.cabinets import CabinetSpec, DoorShelf, DoorSpec, DrawerSpec, Shelf


def shelf_span_m(spec: CabinetSpec, shelf: Shelf) -> tuple[float, float, float]:
    """(left, right) from the body's left edge and depth from the back wall's inner face."""
    t = spec.wall_thickness_m
    left = t if shelf.left_m is None else shelf.left_m
    right = spec.width_m - t if shelf.width_m is None else left + shelf.width_m
    return left, right, spec.inner_depth_m if shelf.depth_m is None else shelf.depth_m


def drawer_box_bounds_m(spec: CabinetSpec, drawer: DrawerSpec) -> tuple[float, float, float, float]:
    """(y_min, y_max, z_min, z_max) of a drawer's box: behind its front, inside the body
    between the walls or dividers either side of the front's middle."""
    t, gap = spec.wall_thickness_m, spec.door_gap_m
    middle = drawer.left_m + drawer.width_m / 2
    inner_left = max([t] + [d.left_m + t for d in spec.dividers if d.left_m + t <= middle])
    inner_right = min([spec.width_m - t] + [d.left_m for d in spec.dividers if d.left_m >= middle])
    # Seen from in front, the body's left edge is at y = -width/2.
    y_min = -spec.width_m / 2 + max(drawer.left_m, inner_left) + gap
    y_max = -spec.width_m / 2 + min(drawer.right_m, inner_right) - gap
    z_min = max(drawer.bottom_m, spec.inner_floor_m) + gap
    z_max = min(drawer.top_m, spec.inner_top_m) - gap
    return y_min, y_max, z_min, z_max


def front_x_m(spec: CabinetSpec) -> float:
    """x of the fronts' outer faces (closed)."""
    return spec.depth_m / 2 + spec.door_gap_m + spec.door_thickness_m


def door_shelf_box_m(spec: CabinetSpec, door: DoorSpec, shelf: DoorShelf) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) corners of a closed door's bin in the model frame."""
    inner_x = spec.depth_m / 2 + spec.door_gap_m
    y0 = -spec.width_m / 2 + door.left_m + shelf.margin_m
    y1 = -spec.width_m / 2 + door.right_m - shelf.margin_m
    z0 = door.bottom_m + shelf.height_m
    return np.array([inner_x - shelf.depth_m, y0, z0]), np.array([inner_x, y1, z0 + shelf.lip_height_m])


def shelf_box_m(spec: CabinetSpec, shelf: Shelf) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) corners of a fixed shelf in the model frame."""
    left, right, depth = shelf_span_m(spec, shelf)
    back = -spec.depth_m / 2 + spec.wall_thickness_m
    y0 = -spec.width_m / 2
    return (
        np.array([back, y0 + left, shelf.height_m - spec.wall_thickness_m]),
        np.array([back + depth, y0 + right, shelf.height_m]),
    )


def drawer_reach_m(spec: CabinetSpec, drawer: DrawerSpec) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) corners of the space a closed drawer's box takes in the model frame."""
    y_min, y_max, z_min, z_max = drawer_box_bounds_m(spec, drawer)
    front = spec.depth_m / 2 + spec.door_gap_m
    return np.array([front - drawer.depth_m, y_min, z_min]), np.array([front, y_max, z_max])
