"""What a turntable reconstruction takes and gives: `ReconstructOptions` and `Reconstruction`.
Their own module, so that the stages (`turntable.reconstruct`) and the export
(`turntable.outputs`) both use them without importing each other."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import trimesh

from articulation.naming import check_model_name
from homemodel.core.checks import check_nested, require_at_least, require_between, require_choice, require_positive
from homemodel.geometry.camera import Camera
from homemodel.model_folder.map_entry import MapEntry
from homemodel.model_folder.result import ModelResult
from turntable.color_encoding import EncodingDecision
from turntable.fusion import Cylinder, MergedCloud
from turntable.meshing import MeshingFigures, MeshingOptions
from turntable.orbit import TableAxis
from turntable.pose import FramePose, PoseOptions
from turntable.tags import DetectionOptions
from turntable.turn_coverage import TurnCoverage
from turntable.turntable_model import TurntableFit


@dataclass(kw_only=True)
class ReconstructOptions:
    detection: DetectionOptions = field(default_factory=DetectionOptions)
    # The colour images' transfer curve, which sets `detection.intensity`: "auto" takes the
    # capture's (a simulated capture's renders are linear; any other capture's is measured from
    # its tag edges, `turntable.color_encoding`: real cameras deliver sRGB, recordings written
    # from simulated frames may be linear).
    color_encoding: Literal["auto", "linear", "srgb"] = "auto"
    pose: PoseOptions = field(default_factory=PoseOptions)
    meshing: MeshingOptions = field(default_factory=MeshingOptions)
    voxel_size_m: float = 0.0015
    plane_margin_m: float = 0.004  # the object starts this far above the table top (clears its depth noise)
    cylinder_radius_m: float | None = None  # None: the table's radius about the axis, less 1 cm
    max_height_m: float = 1.0
    min_frames: int = 3
    turntable_refinement: bool = True  # refine all poses together under the turntable's motion
    # 0: no texture (vertex colours in the PLY only). The texture carries the carrier's 6,000
    # vertex colours, linear over each triangle: on the bench mug's 40 frames (20,000 surface
    # points against the full mesh's colours) 512 px differ by 3.82 of 255 on average, 1024 px by
    # 3.80, 384 px by 3.91 (16 CPU-ms less, but not a power of two: WebGL 1 viewers cannot
    # mipmap it), 256 px by 4.77.
    texture_size_px: int = 512
    texture_max_triangles: int = 12_000  # the texture's carrier is decimated to this
    workers: int = 2  # threads reading images and detecting tags
    # Predict each frame's tags from the two before it (the table turns evenly) and search
    # the image only where the prediction fails (see `turntable.tag_search.tracked_pose`).
    predict_tags: bool = True
    # Real sensors' frames (turntable.real_frames):
    blur_ratio: float = 0.35  # frames sharper than this fraction of the median only are skipped; 0: none
    drop_flying_pixels: bool = True
    misregistration_warning_px: float = 1.5  # depth edges farther than this from colour edges: warned
    # The model folder (`reconstruct`):
    name: str = "turntable_object"  # the model's name
    density_kg_m3: float = 500.0  # for the inertial
    picture: bool = False  # also draw picture.png: the mesh with the camera orbit
    map_entry: MapEntry | None = None  # register the model into this map (its object_id: default `name`)

    def check(self) -> None:
        check_nested("detection", self.detection)
        require_choice("color_encoding", self.color_encoding, ("auto", "linear", "srgb"))
        check_nested("pose", self.pose)
        check_nested("meshing", self.meshing)
        require_positive("voxel_size_m", self.voxel_size_m)
        require_at_least("plane_margin_m", self.plane_margin_m, 0.0)
        if self.cylinder_radius_m is not None:
            require_positive("cylinder_radius_m", self.cylinder_radius_m)
        require_positive("max_height_m", self.max_height_m)
        require_at_least("min_frames", self.min_frames, 1)
        require_at_least("texture_size_px", self.texture_size_px, 0)
        require_at_least("texture_max_triangles", self.texture_max_triangles, 100)
        require_at_least("workers", self.workers, 1)
        require_between("blur_ratio", self.blur_ratio, 0.0, 1.0)
        require_positive("misregistration_warning_px", self.misregistration_warning_px)
        require_positive("density_kg_m3", self.density_kg_m3)
        check_model_name(self.name)


@dataclass(kw_only=True)
class Reconstruction(ModelResult):
    """The mesh in the table frame with its colours, and every figure the summary reports."""

    mesh: trimesh.Trimesh
    vertex_colors: np.ndarray  # (V, 3) in [0, 1]
    textured_mesh: trimesh.Trimesh | None  # split along UV seams
    uv: np.ndarray | None
    texture: np.ndarray | None  # (H, W, 3) uint8
    camera: Camera  # the capture's, which every pose in `poses` is seen with
    poses: dict[str, FramePose]
    skipped: dict[str, str]  # frame stem -> "image: ...", "pose: ..." or "unpaired: ..."
    axis: TableAxis
    turntable_fit: TurntableFit | None
    turn: TurnCoverage  # the merged frames' share of the turn and largest gap
    cylinder: Cylinder
    table_noise_m: float  # how far the table top's depth noise reaches (`table_noise_m`); the cylinder starts above it
    cloud: MergedCloud
    meshing: MeshingFigures
    times_s: dict[str, float]  # seconds per stage; `reconstruct` adds the export's
    frames_total: int
    color_encoding: EncodingDecision  # the curve the tag edges were refined with, and how it was decided
    real_frames: dict = field(default_factory=dict)  # flying pixels, blur, misregistration (turntable.real_frames)
    recording: dict | None = None  # the capture's recording.json, when imported from a recording

    def figures(self) -> dict:
        """The turntable's own figures (summary.json's `turntable` key, with its times and extent)."""
        tags = np.array([p.tags for p in self.poses.values()])
        errors = np.array([p.reprojection_error_px for p in self.poses.values()])
        reasons: dict[str, int] = {}
        for reason in self.skipped.values():  # "kind: details", kind one of image, pose, unpaired
            kind = reason.split(":", 1)[0]
            reasons[kind] = reasons.get(kind, 0) + 1
        return {
            "frames_total": self.frames_total,
            "frames_used": len(self.poses),
            "frames_skipped": len(self.skipped),
            "skip_reasons": reasons,
            "tags_per_frame": {"mean": float(tags.mean()), "min": int(tags.min()), "max": int(tags.max())},
            "reprojection_error_px": {"mean": float(errors.mean()), "max": float(errors.max())},
            "orbit": {
                "radius_m": self.axis.orbit.radius_m,
                "circle_rms_m": self.axis.orbit.rms_m,
                "axis_xy_m": self.axis.axis_xy_m.tolist(),
                "axis_tilt_deg": self.axis.tilt_deg,
                "axis_spread_m": self.axis.axis_spread_m,
            },
            "turntable_refinement": None
            if self.turntable_fit is None
            else {
                "accepted": self.turntable_fit.accepted,
                "rms_px": self.turntable_fit.rms_px,
                "pnp_rms_px": self.turntable_fit.pnp_rms_px,
            },
            "turn": self.turn.figures(),
            "color_encoding": self.color_encoding.figures(),
            "cylinder": {
                "radius_m": self.cylinder.radius_m,
                "z_min_m": self.cylinder.z_min_m,
                "table_noise_m": self.table_noise_m,
            },
            "points_merged": self.meshing.points_in,
            "points_after_outlier_removal": self.meshing.points_after_outliers,
            "triangles_poisson": self.meshing.triangles_poisson,
            "triangles": self.meshing.triangles,
            "density_trimmed": self.meshing.density_trimmed,
            "watertight": bool(self.mesh.is_watertight),
            "extent_m": np.ptp(self.mesh.vertices, axis=0).tolist(),
            "real_frames": self.real_frames,
            "recording": self.recording,
            "times_s": dict(self.times_s),
        }
