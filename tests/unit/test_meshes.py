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


def _signed_areas(verts: np.ndarray, tri: np.ndarray) -> np.ndarray:
    p = verts[tri.reshape(-1, 3), :][:, :, [0, 2]].astype(np.float64)
    a, b, c = p[:, 0], p[:, 1], p[:, 2]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1]))


def _border_edges(tri: np.ndarray) -> set[tuple[int, int]]:
    """The edges used by one triangle only: a chunk's outline."""
    t = tri.reshape(-1, 3)
    edges = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    uniq, counts = np.unique(edges, axis=0, return_counts=True)
    return {tuple(e) for e in uniq[counts == 1].tolist()}


def test_every_level_of_detail_tiles_each_chunk_and_keeps_its_full_border():
    """At strides 2 and 4 (meshes.LOD_STRIDES) each chunk's triangles cover its square once
    (areas sum to it, none degenerate, all wound as the grid's), and its outline is the
    grid's own, every grid vertex on it: chunks drawn at different levels meet without a
    crack, and the far land (fanned onto the grid's edge) still meets them."""
    m = meshes.build("countryside")
    n = meshes.TERRAIN_CELLS
    verts = m.terrain_vertices
    cell = 2 * terrain.EXTENT / (n - 1)
    fine_sign = np.sign(_signed_areas(verts, m.terrain_indices[:6]))[0]
    for first, count, *_, f2, c2, f4, c4 in m.terrain_chunks.astype(int):
        fine = m.terrain_indices[first:first + count]
        outline = _border_edges(fine)
        square = np.abs(_signed_areas(verts, fine)).sum()
        for f, c in ((f2, c2), (f4, c4)):
            coarse = m.terrain_indices[f:f + c]
            areas = _signed_areas(verts, coarse)
            assert bool(np.all(np.sign(areas) == fine_sign)) == True   # noqa: E712
            assert float(np.abs(areas).min()) > 0.25 * cell * cell
            assert float(np.abs(areas).sum()) == pytest.approx(float(square), rel=1e-6)
            assert _border_edges(coarse) == outline
            assert c < count / 2.5


def test_the_indexed_objects_are_their_triangles_with_each_vertex_once():
    tris = meshes.build("countryside").objects
    verts, idx = meshes.indexed(tris)
    assert idx.dtype == np.uint32
    assert np.array_equal(verts[idx], tris)   # every corner, in order, exactly
    assert len(np.unique(verts, axis=0)) == len(verts)
    assert len(verts) < 0.5 * len(tris)       # shared corners are shaded once


def _plane_height_at(verts: np.ndarray, tri: np.ndarray, x: float, z: float) -> float:
    """The height at (x, z) of the triangle that covers it, found by trying every one
    (world coordinates, float64)."""
    p = verts[tri.reshape(-1, 3)].astype(np.float64)
    a, b, c = p[:, 0], p[:, 1], p[:, 2]
    d = (b[:, 0] - a[:, 0]) * (c[:, 2] - a[:, 2]) - (c[:, 0] - a[:, 0]) * (b[:, 2] - a[:, 2])
    u = ((x - a[:, 0]) * (c[:, 2] - a[:, 2]) - (c[:, 0] - a[:, 0]) * (z - a[:, 2])) / d
    v = ((b[:, 0] - a[:, 0]) * (z - a[:, 2]) - (x - a[:, 0]) * (b[:, 2] - a[:, 2])) / d
    k = int(np.argmax(np.minimum(np.minimum(u, v), 1.0 - u - v)))   # the most inside
    return float(a[k, 1] + u[k] * (b[k, 1] - a[k, 1]) + v[k] * (c[k, 1] - a[k, 1]))


def test_each_level_of_details_error_is_the_largest_height_gap_at_a_grid_vertex():
    """meshes.lod_errors (solved in grid units) against a search in world coordinates: at
    every grid vertex of a chunk, the height of the coarse triangle over it."""
    m = meshes.build("countryside")
    verts, n = m.terrain_vertices, meshes.TERRAIN_CELLS
    table = m.terrain_chunks.astype(int)
    ranges = meshes._chunk_ranges(n)
    assert m.terrain_lod_error.shape == (len(table), len(meshes.LOD_STRIDES))
    assert np.all(m.terrain_lod_error[:, 0] == 0.0)
    for k in (0, 27, 36):   # a corner; the river and the road; the river south of the road
        i0, i1, j0, j1 = ranges[k]
        I, J = np.meshgrid(np.arange(i0, i1 + 1), np.arange(j0, j1 + 1), indexing="xy")
        grid = (J * n + I).ravel()
        for level in (1, 2):
            f, c = table[k, 4 + 2 * level], table[k, 5 + 2 * level]
            coarse = m.terrain_indices[f:f + c]
            gap = max(abs(_plane_height_at(verts, coarse, float(verts[g, 0]), float(verts[g, 2]))
                          - float(verts[g, 1])) for g in grid)
            assert m.terrain_lod_error[k, level] == pytest.approx(gap, abs=1e-5)
    # where the ground is smooth, the coarse levels are close; across the river, not
    assert m.terrain_lod_error[0, 2] < 0.1 and m.terrain_lod_error[27, 2] > 0.3
