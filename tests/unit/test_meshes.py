"""The countryside's far skirt (scene/meshes.py) against the detailed terrain grid."""

from __future__ import annotations

import numpy as np
import pytest

from fogbank.scene import meshes, terrain


def test_the_far_skirt_meets_the_detailed_terrain_without_crack_or_overlap():
    """Every vertex on the detailed grid's edge is a vertex of the skirt too (the same x, z
    and height: no crack at the seam), no skirt vertex lies inside the detailed square (no
    coarse facet above the fine terrain there), and the skirt reaches SKIRT_OUTER."""
    E = terrain.EXTENT
    skirt = meshes._far_skirt()[:, :3].astype(np.float64)
    grid = meshes._terrain_grid()[0][:, :3].astype(np.float64)
    edge = grid[(np.abs(np.abs(grid[:, 0]) - E) < 1e-3) | (np.abs(np.abs(grid[:, 2]) - E) < 1e-3)]
    shared = {tuple(v) for v in np.round(skirt, 3)}
    assert len(edge) == 4 * (meshes.TERRAIN_CELLS - 1)
    assert sum(tuple(v) in shared for v in np.round(edge, 3)) == len(edge)
    inside = (np.abs(skirt[:, 0]) < E - 1e-3) & (np.abs(skirt[:, 2]) < E - 1e-3)
    assert int(inside.sum()) == 0
    assert float(np.abs(skirt[:, [0, 2]]).max()) == meshes.SKIRT_OUTER
    assert np.allclose(skirt[:, 1], terrain.height(skirt[:, 0], skirt[:, 2]), atol=1e-3)


def test_the_far_skirt_and_the_terrain_tile_the_plane_exactly():
    """Projected onto the ground plane, the detailed terrain's and the skirt's triangles
    cover the square of side 2 SKIRT_OUTER once: their areas sum to its area, none is
    degenerate (a fan with a wrong corner leaves a gap, an overlap adds area)."""
    def areas(p):
        a, b, c = p[0::3], p[1::3], p[2::3]
        return 0.5 * np.abs((b[:, 0] - a[:, 0]) * (c[:, 2] - a[:, 2]) - (c[:, 0] - a[:, 0]) * (b[:, 2] - a[:, 2]))
    skirt = meshes._far_skirt()[:, :3].astype(np.float64)
    verts, idx, _ = meshes._terrain_grid()
    grid = verts[idx, :3].astype(np.float64)
    sa, ga = areas(skirt), areas(grid)
    assert float(sa.min()) > 0.0
    assert float(ga.sum()) == pytest.approx((2 * terrain.EXTENT) ** 2, rel=1e-6)
    assert float(sa.sum() + ga.sum()) == pytest.approx((2 * meshes.SKIRT_OUTER) ** 2, rel=1e-6)
