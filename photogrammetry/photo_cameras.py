"""Which camera took each photo, at what focal length, held which way up (from EXIF).

COLMAP shares one camera model between photos only when they come from the same camera at
the same zoom, starts from the EXIF focal length when there is one, and reads pixels as
stored: a portrait photo whose EXIF says "turn me" would be matched lying on its side. So
photos are grouped by camera here, and turned photos are written upright into the work folder
(with the photos renamed there when a name cannot go into COLMAP's pair lists).
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

from homemodel.core.errors import InputError
from homemodel.core.images import read_image, read_image_size

# EXIF tags (the Exif IFD and the main IFD).
_EXIF_IFD = 0x8769
_MAKE, _MODEL, _ORIENTATION = 0x010F, 0x0110, 0x0112
_FOCAL_35MM = 0xA405
_FOCAL_MM, _PLANE_X_RES, _PLANE_RES_UNIT = 0x920A, 0xA20E, 0xA210
_PIXEL_X, _PIXEL_Y = 0xA002, 0xA003  # the size the camera wrote
_MM_PER_RES_UNIT = {2: 25.4, 3: 10.0, 4: 1.0}  # inch, cm, mm
FULL_FRAME_WIDTH_MM = 36.0


@dataclass(frozen=True, kw_only=True)
class PhotoCamera:
    """What a photo's header says about its camera; `width`/`height` are of the upright photo."""

    make: str
    model: str
    width: int
    height: int
    focal_px: float | None  # from EXIF, at this size; None when the photo does not say
    turned: bool  # EXIF orientation asks for a turn or a mirror

    @property
    def key(self) -> tuple:
        """Photos with one key share one camera model (intrinsics and distortion)."""
        focal = None if self.focal_px is None else round(self.focal_px)
        return (self.make, self.model, self.width, self.height, focal)


def _focal_px(exif, longest_px: int) -> float | None:
    """The focal length in pixels: from the 35 mm equivalent, else from the focal plane resolution."""
    details = exif.get_ifd(_EXIF_IFD)
    f35 = details.get(_FOCAL_35MM)
    if f35:
        return float(f35) / FULL_FRAME_WIDTH_MM * longest_px
    focal_mm, x_res, unit = details.get(_FOCAL_MM), details.get(_PLANE_X_RES), details.get(_PLANE_RES_UNIT, 2)
    if focal_mm and x_res and unit in _MM_PER_RES_UNIT:
        focal = float(focal_mm) * float(x_res) / _MM_PER_RES_UNIT[unit]  # at the size the camera wrote
        written = max(int(details.get(_PIXEL_X, 0) or 0), int(details.get(_PIXEL_Y, 0) or 0))
        return focal * longest_px / written if written else focal  # a resized photo: its focal resized too
    return None


def read_photo_camera(path: Path) -> PhotoCamera:
    """The camera of one photo (a file `list_photos` accepted), from its header only."""
    from PIL import Image, UnidentifiedImageError

    height, width = read_image_size(path)
    try:
        with Image.open(path) as image:
            exif = image.getexif()
    except (OSError, UnidentifiedImageError, SyntaxError) as error:
        raise InputError(f"{path}: not a readable image: {error}") from error
    turned = exif.get(_ORIENTATION, 1) not in (1, None)
    if exif.get(_ORIENTATION) in (5, 6, 7, 8):  # a quarter turn swaps the sides
        width, height = height, width
    try:
        focal = _focal_px(exif, max(width, height))
    except (TypeError, ValueError, ZeroDivisionError):
        focal = None  # a malformed tag is no prior, not an error
    return PhotoCamera(
        make=str(exif.get(_MAKE, "")).strip("\x00 "),
        model=str(exif.get(_MODEL, "")).strip("\x00 "),
        width=width,
        height=height,
        focal_px=focal if focal and focal > 0 else None,
        turned=turned,
    )


def group_by_camera(cameras: dict[str, PhotoCamera]) -> list[list[str]]:
    """Photo names grouped by camera (one group per camera model), in name order."""
    groups: dict[tuple, list[str]] = {}
    for name in sorted(cameras):
        groups.setdefault(cameras[name].key, []).append(name)
    return list(groups.values())


def listable(name: str) -> bool:
    """Whether COLMAP's pair lists can hold `name`: each line is "name1 name2", split at
    spaces, and a line starting with '#' is a comment."""
    return not any(c.isspace() for c in name) and not name.startswith("#")


def sfm_photo_folder(photos: list[Path], cameras: dict[str, PhotoCamera], work_dir: Path) -> tuple[Path, dict[str, str]]:
    """The folder SfM reads and the name each photo has there, by its own name: the photos'
    own folder and names; or, when some must be turned or a name cannot go into COLMAP's pair
    lists ("IMG 0001.jpg": no pair of it was matched, nothing registered), a folder in
    `work_dir` with the turned photos written upright and links to the rest, every photo then
    named after its place in name order and its name with spaces made '_' (the same order,
    so the same image ids and the same model)."""
    import cv2

    renamed = not all(listable(p.name) for p in photos)
    if not renamed and not any(c.turned for c in cameras.values()):
        return photos[0].parent, {p.name: p.name for p in photos}
    folder = work_dir / "photos"
    folder.mkdir(parents=True, exist_ok=True)
    names = {}
    for index, path in enumerate(sorted(photos)):
        names[path.name] = f"{index:05d}_{''.join('_' if c.isspace() else c for c in path.name)}" if renamed else path.name
        target = folder / names[path.name]
        if cameras[path.name].turned:
            # OpenCV's default decode applies the EXIF orientation; writing drops the tag.
            ok, data = cv2.imencode(path.suffix, read_image(path), [cv2.IMWRITE_JPEG_QUALITY, 97])
            if not ok:
                raise InputError(f"{path}: cannot write it upright")
            target.write_bytes(data.tobytes())
        else:
            try:
                target.symlink_to(path.resolve())
            except OSError:
                shutil.copyfile(path, target)
    return folder, names
