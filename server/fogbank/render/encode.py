"""Image encoding: JPEG (libjpeg-turbo via simplejpeg, releases the GIL), PNG and WebP
(Pillow). Deterministic: the same pixels give the same bytes."""

from __future__ import annotations

import io

import numpy as np
import simplejpeg
from PIL import Image

MEDIA_TYPES = {"png": "image/png", "jpg": "image/jpeg", "webp": "image/webp"}


def encode(img: np.ndarray, fmt: str, quality: int = 90) -> bytes:
    """`img`: (height, width, 3) RGB or (height, width, 4) RGBX uint8, top row first."""
    rgbx = img.shape[2] == 4
    if fmt == "jpg":
        return simplejpeg.encode_jpeg(np.ascontiguousarray(img), quality=quality,
                                      colorspace="RGBX" if rgbx else "RGB", colorsubsampling="420")
    if rgbx:
        img = img[..., :3]   # a frame read for a JPEG, asked as a PNG or WebP (Pillow copies it)
    buf = io.BytesIO()
    if fmt == "png":
        Image.fromarray(img).save(buf, format="PNG", compress_level=3)
    elif fmt == "webp":
        Image.fromarray(img).save(buf, format="WEBP", quality=quality, method=2)
    else:
        raise ValueError(f"unknown image format {fmt!r}; one of png, jpg, webp")
    return buf.getvalue()
