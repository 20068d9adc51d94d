"""The photo folder a reconstruction starts from: which files are photos, and can they be read."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from homemodel.core.errors import InputError
from homemodel.core.images import read_image, read_image_size

PHOTO_SUFFIXES = (".jpg", ".jpeg", ".png", ".tif", ".tiff", ".bmp")
MIN_SIDE_PX = 64


def list_photos(folder: Path) -> list[Path]:
    """The photos in `folder` (by suffix, sorted by name; other files and hidden ones are
    ignored), each checked to decode as an image of at least MIN_SIDE_PX pixels a side."""
    import cv2

    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{folder}: not a folder of photos")
    # Hidden files are no photos: a folder copied from a Mac holds "._IMG_0001.JPG" beside each
    # photo (its AppleDouble metadata, not an image).
    photos = sorted(
        p for p in folder.iterdir() if p.suffix.lower() in PHOTO_SUFFIXES and not p.name.startswith(".") and p.is_file()
    )
    if not photos:
        raise InputError(f"{folder}: holds no photos ({', '.join(PHOTO_SUFFIXES)})")
    for path in photos:
        # IMREAD_REDUCED_GRAYSCALE_8 decodes at 1/8 size: fast, and still fails on a corrupt file.
        read_image(path, cv2.IMREAD_REDUCED_GRAYSCALE_8)
        height, width = read_image_size(path)
        if min(height, width) < MIN_SIDE_PX:
            raise InputError(f"{path}: {width}x{height} px is too small (at least {MIN_SIDE_PX} px a side)")
    return photos


def read_rgb(path: Path, *, max_side_px: int | None = None) -> np.ndarray:
    """An 8-bit RGB image, shrunk (area averaging) so its longer side is at most `max_side_px`."""
    import cv2

    image = cv2.cvtColor(read_image(path), cv2.COLOR_BGR2RGB)
    if max_side_px is not None and max(image.shape[:2]) > max_side_px:
        scale = max_side_px / max(image.shape[:2])
        size = (round(image.shape[1] * scale), round(image.shape[0] * scale))
        image = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
    return image
