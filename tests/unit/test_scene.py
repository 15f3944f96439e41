"""The scene pass's choice of each terrain chunk's level of detail (render/passes/scene.py)."""

from __future__ import annotations

import math

import numpy as np

from fogbank.render.passes.scene import LOD_ERROR_PX, lod_levels


def _distance_for(px_per_m: float, fov: float, height: int) -> float:
    """The distance (m) at which one metre spans px_per_m pixels: the pinhole projection,
    written out here apart from the pass."""
    return height / (2.0 * math.tan(math.radians(fov) / 2.0) * px_per_m)


def test_each_chunk_takes_the_coarsest_level_whose_error_is_within_a_pixel():
    error = np.array([[0.0, 0.1, 0.5],     # smooth ground
                      [0.0, 0.1, 0.5],
                      [0.0, 0.4, 0.3],     # a coarser level may be closer
                      [0.0, 2.0, 8.0]])    # a river's banks
    fov, height = 55.0, 720
    assert LOD_ERROR_PX == 1.0
    # 10 px a metre: 0.1 m is one pixel, 0.5 m five
    near = np.full(4, _distance_for(10.0, fov, height) * (1 + 1e-9))
    assert lod_levels(near, error, fov, height).tolist() == [1, 1, 0, 0]
    # 2 px a metre: 0.5 m is one pixel; 0.3 m 0.6 px; 2 m four pixels
    far = np.full(4, _distance_for(2.0, fov, height) * (1 + 1e-9))
    assert lod_levels(far, error, fov, height).tolist() == [2, 2, 2, 0]
    # at the eye nothing is coarser; a quarter of the height, a quarter of the pixels:
    # 2.5 px a metre, and the third chunk's level 2 (0.75 px) is within where level 1 was not
    assert lod_levels(np.zeros(4), error, fov, height).tolist() == [0, 0, 0, 0]
    assert lod_levels(near, error, fov, height // 4).tolist() == [1, 1, 2, 0]
