"""Image encoding: JPEG (libjpeg-turbo via simplejpeg, releases the GIL), PNG and WebP
(Pillow). Deterministic: the same pixels give the same bytes."""

from __future__ import annotations

import io

import numpy as np
import simplejpeg
from PIL import Image

MEDIA_TYPES = {"png": "image/png", "jpg": "image/jpeg", "webp": "image/webp"}


def encode(img: np.ndarray, fmt: str, quality: int = 90) -> bytes:
    if fmt == "jpg":
        return simplejpeg.encode_jpeg(np.ascontiguousarray(img), quality=quality,
                                      colorspace="RGB", colorsubsampling="420")
    buf = io.BytesIO()
    if fmt == "png":
        Image.fromarray(img).save(buf, format="PNG", compress_level=3)
    elif fmt == "webp":
        Image.fromarray(img).save(buf, format="WEBP", quality=quality, method=2)
    else:
        raise ValueError(f"unknown image format {fmt!r}; one of png, jpg, webp")
    return buf.getvalue()
