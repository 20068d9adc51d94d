"""Whether a model that joined groups of photos kept each group's geometry and its aim.

When the first mapping pass leaves the photos in groups, the fallbacks (a second, relaxed pass
and COLMAP's global mapper) join them through the few pairs that link the groups. On 26
Buddha photos all round, six lower photos in front link to the rest through one pair (90
inliers), and the global mapper set them in the wrong place: every photo "registers" at a low
reprojection error (0.53 px), yet the cameras are wrong (median centre 0.33 of the cameras'
spread, 22 degrees of rotation, against the reference cameras). Each first-pass group was built photo by photo, every one checked by
its reprojection errors, so a joined model must hold each group's cameras where the group put
them, up to a similarity, as a loop of relative poses must close. That alone does not see the
wrong join above: both groups keep their shape (to 0.012 of their spread) but one sits in the
wrong place, so its six photos look past what the others look at. So a group that looked at
one point must still look at the joined model's focus (`lost_focus`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from photogrammetry.pose_agreement import PoseAgreement, pose_agreement
from photogrammetry.support_plane import focus_point

# A joined model and a group's own model are two solutions of the same photos: on the 33
# all-round Buddha photos they agree to 0.008 of the spread and 0.32 degrees at most.
MAX_CENTRE_ERROR = 0.05  # share of the group's camera spread
MAX_ROTATION_ERROR_DEG = 3.0
# A group "looked at one point" when at least this share of its photos had its focus in frame;
# the joined model loses it when under half as many see the joined focus (wrong joins: 0 % and
# 6 % of groups that had 100 %; right joins: 100 %).
MIN_FOCUS_SHARE = 0.5


def camera_poses(reconstruction) -> dict[str, np.ndarray]:
    """`camera_from_world` (4x4) of each registered image of a pycolmap reconstruction, by name."""
    poses = {}
    for image in reconstruction.images.values():
        if image.has_pose:
            pose = np.eye(4)
            pose[:3, :] = image.cam_from_world().matrix()
            poses[image.name] = pose
    return poses


@dataclass(kw_only=True)
class GroupAgreement:
    photos: int  # the group's photos that the joined model holds
    agreement: PoseAgreement

    @property
    def holds(self) -> bool:
        return (
            self.agreement.max_centre_error <= MAX_CENTRE_ERROR
            and self.agreement.max_rotation_error_deg <= MAX_ROTATION_ERROR_DEG
        )


def group_agreements(joined, groups: list) -> list[GroupAgreement]:
    """How the joined reconstruction's cameras agree with each group's reconstruction (groups
    of fewer than three photos in common say nothing: any similarity fits them)."""
    joined_poses = camera_poses(joined)
    found = []
    for group in groups:
        own = camera_poses(group)
        common = set(own) & set(joined_poses)
        if len(common) >= 3:
            agreement = pose_agreement({n: joined_poses[n] for n in common}, {n: own[n] for n in common})
            found.append(GroupAgreement(photos=len(common), agreement=agreement))
    return found


def bent_group(joined, groups: list) -> str | None:
    """None when the joined model keeps every group's geometry, else why not (one line)."""
    for found in group_agreements(joined, groups):
        if not found.holds:
            a = found.agreement
            return (
                f"a group of {found.photos} photos is bent by the join: cameras moved by up to "
                f"{a.max_centre_error:.2f} of their spread and turned by up to {a.max_rotation_error_deg:.1f} degrees"
            )
    return None


def _focus(reconstruction, names: list[str]) -> np.ndarray:
    """The point the named images' optical axes pass closest to."""
    images = [reconstruction.find_image_with_name(n) for n in names]
    centres = np.array([im.projection_center() for im in images])
    return focus_point(centres, np.array([im.viewing_direction() for im in images]))


def _sees(reconstruction, names: list[str], point: np.ndarray) -> float:
    """The share of the named images that have `point` in front and inside their frame."""
    seen = 0
    for name in names:
        image = reconstruction.find_image_with_name(name)
        camera_point = image.cam_from_world() * point
        pixel = image.project_point(point)
        camera = reconstruction.cameras[image.camera_id]
        seen += bool(
            camera_point[2] > 0
            and pixel is not None
            and 0 <= pixel[0] <= camera.width
            and 0 <= pixel[1] <= camera.height
        )
    return seen / len(names)


def lost_focus(joined, groups: list) -> str | None:
    """None when each group that looked at one point before the join (most of its photos had
    their group's focus in frame) still looks at the joined model's focus, else why not.
    Photos taken round an object keep it in frame; a group joined in the wrong place looks
    past it (the six lower front photos of the wrong 26-photo Buddha join: none of six)."""
    joined_names = sorted(camera_poses(joined))
    focus = _focus(joined, joined_names)
    for group in groups:
        names = sorted(set(camera_poses(group)) & set(joined_names))
        if len(names) < 3:
            continue
        own = _sees(group, names, _focus(group, names))
        now = _sees(joined, names, focus)
        if own >= MIN_FOCUS_SHARE and now < own / 2:
            return (
                f"a group of {len(names)} photos looked at one point ({own:.0%} had it in frame) but only "
                f"{now:.0%} of them see what the joined model's photos look at"
            )
    return None


def refusal(joined, groups: list) -> str | None:
    """None when the joined reconstruction keeps every first-pass group's geometry and aim,
    else why it is refused."""
    return bent_group(joined, groups) or lost_focus(joined, groups)
