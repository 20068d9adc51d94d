"""What `observe` found, per object in view: the report JSON (`--report`) and the table the
command prints. Poses are written as xyz (m) and rpy (rad), as the map file holds them."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from homemodel.core.transforms import xyz_rpy_from_transform


def pose_json(a_from_b: np.ndarray) -> dict[str, list[float]]:
    xyz, rpy = xyz_rpy_from_transform(np.asarray(a_from_b, dtype=np.float64))
    return {"xyz": [round(float(v), 6) for v in xyz], "rpy": [round(float(v), 6) for v in rpy]}


def _number(value: float, digits: int = 6) -> float | None:
    return None if value is None or not math.isfinite(value) else round(float(value), digits)


@dataclass(kw_only=True)
class JointReport:
    """A joint's estimate, or why there is none (`status`)."""

    name: str
    type: str
    # "doubtful": fitted, but the model at the estimate explains none of the part's points
    status: Literal["fitted", "partly seen", "doubtful", "not seen", "ambiguous"]
    position: float  # the map's new position (the old one unless fitted), rad or m
    previous: float
    estimate: float = float("nan")  # the fit's position, also when it did not go into the map
    visible_fraction: float = 0.0
    residual_m: float = float("nan")
    unexplained: float = float("nan")  # the part's mean truncated squared residual over the tolerance: 0 to 1
    pixels: int = 0

    def to_json(self) -> dict:
        out: dict = {"name": self.name, "type": self.type, "status": self.status}
        if self.status == "fitted":
            out |= {"position": _number(self.position), "previous": _number(self.previous)}
        else:
            out |= {"position": None, "kept": _number(self.previous)}
            if self.status in ("partly seen", "doubtful"):
                out["estimate"] = _number(self.estimate)
        return out | {
            "visible_fraction": _number(self.visible_fraction, 3),
            "residual_m": _number(self.residual_m),
            "unexplained": _number(self.unexplained, 3),
            "pixels": self.pixels,
        }


@dataclass(kw_only=True)
class SmallObjectReport:
    """A small object looked for: found (with where), not found, or not seen (where it
    should be is out of view or covered)."""

    id: str
    status: Literal["found", "not found", "not seen"]
    parent: str  # after the observation (a moved object's new parent)
    previous_parent: str
    relation: str = "on"  # to the parent
    map_from_object: np.ndarray | None = None  # where it was found
    parent_from_object: np.ndarray | None = None
    inlier_fraction: float = 0.0
    rmse_m: float = float("nan")
    yaw_seen: bool = True  # False: the view did not pin the yaw, the map's (or the nearest it allows) kept

    def to_json(self) -> dict:
        out: dict = {"id": self.id, "status": self.status, "parent": self.parent, "relation": self.relation}
        if self.parent != self.previous_parent:
            out["moved_from"] = self.previous_parent
        if self.status == "found":
            out |= {
                "map_from_object": pose_json(self.map_from_object),
                "parent_from_object": pose_json(self.parent_from_object),
                "inlier_fraction": _number(self.inlier_fraction, 3),
                "rmse_m": _number(self.rmse_m),
                "yaw": "seen" if self.yaw_seen else "not seen",
            }
        return out


@dataclass(kw_only=True)
class ObjectReport:
    """A large object in view: its refined pose and its joints; the small objects on, in
    or under it (or found on it)."""

    id: str
    type: str
    pixels: int  # observed pixels where the map puts it first (in the coarse view)
    map_from_object: np.ndarray
    previous_map_from_object: np.ndarray
    pose_refined: bool
    pose_note: str = ""  # why the refined pose was taken or the map's kept
    pose_inlier_fraction: float = 0.0
    pose_rmse_m: float = float("nan")
    seconds: float = 0.0
    joints: list[JointReport] = field(default_factory=list)
    small_objects: list[SmallObjectReport] = field(default_factory=list)

    @property
    def shift_m(self) -> float:
        return float(np.linalg.norm(self.map_from_object[:3, 3] - self.previous_map_from_object[:3, 3]))

    @property
    def turn_deg(self) -> float:
        relative = self.map_from_object[:3, :3] @ self.previous_map_from_object[:3, :3].T
        return float(np.degrees(np.arccos(np.clip((np.trace(relative) - 1) / 2, -1.0, 1.0))))

    def to_json(self) -> dict:
        return {
            "id": self.id,
            "type": self.type,
            "pixels": self.pixels,
            "pose_refined": self.pose_refined,
            "pose_note": self.pose_note,
            "map_from_object": pose_json(self.map_from_object),
            "previous_map_from_object": pose_json(self.previous_map_from_object),
            "shift_m": _number(self.shift_m),
            "turn_deg": _number(self.turn_deg, 3),
            "pose_inlier_fraction": _number(self.pose_inlier_fraction, 3),
            "pose_rmse_m": _number(self.pose_rmse_m),
            "seconds": _number(self.seconds, 3),
            "joints": [j.to_json() for j in self.joints],
            "small_objects": [s.to_json() for s in self.small_objects],
        }


@dataclass(kw_only=True)
class ObservationReport:
    """Every object in view; `nothing_seen` when the depth image holds no reading."""

    observation: str
    nothing_seen: bool
    objects: list[ObjectReport] = field(default_factory=list)
    times_s: dict[str, float] = field(default_factory=dict)

    def to_json(self) -> dict:
        return {
            "observation": self.observation,
            "nothing_seen": self.nothing_seen,
            "objects": [o.to_json() for o in self.objects],
            "times_s": {k: round(v, 4) for k, v in self.times_s.items()},
        }

    def table_rows(self) -> list[tuple[str, str, str, str]]:
        """(object, what, estimate, support) rows for the command's table."""
        rows = []
        for obj in self.objects:
            pose = f"moved {obj.shift_m * 100:.1f} cm, {obj.turn_deg:.1f} deg" if obj.pose_refined else f"kept: {obj.pose_note}"
            rows.append((obj.id, "pose", pose, f"{obj.pixels} px"))
            for joint in obj.joints:
                if joint.status == "fitted":
                    value = f"{np.degrees(joint.position):.1f} deg" if joint.type != "prismatic" else f"{joint.position * 1000:.0f} mm"
                    support = f"{joint.visible_fraction:.0%} visible"
                else:
                    value, support = joint.status, f"{joint.visible_fraction:.0%} visible"
                rows.append((obj.id, joint.name, value, support))
            for small in obj.small_objects:
                where = small.status
                if small.status == "found":
                    x, y, z = small.map_from_object[:3, 3]
                    where = f"found at ({x:.2f}, {y:.2f}, {z:.2f}) m" + ("" if small.yaw_seen else ", yaw not seen")
                    if small.parent != small.previous_parent:
                        where += f", moved from {small.previous_parent}"
                rows.append((obj.id, small.id, where, ""))
        return rows
