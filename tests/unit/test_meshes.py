"""The countryside's terrain (scene/meshes.py): the far skirt against the detailed grid, and
the chunks' levels of detail with their skirts."""

from __future__ import annotations

import numpy as np
import pytest

from fogbank.scene import meshes, terrain


def test_the_far_skirt_meets_the_detailed_terrain_without_crack_or_overlap():
    """Every vertex on the detailed grid's edge is a vertex of the skirt too (the same x, z
    and height: no crack at the seam), no skirt vertex lies inside the detailed square (no
    coarse facet above the fine terrain there), and the skirt reaches SKIRT_OUTER."""
    E = terrain.EXTENT
    skirt = meshes._far_skirt()[0][:, :3].astype(np.float64)
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
    skirt = meshes._far_skirt()[0][:, :3].astype(np.float64)
    verts, idx, _ = meshes._terrain_grid()
    grid = verts[idx, :3].astype(np.float64)
    sa, ga = areas(skirt), areas(grid)
    assert float(sa.min()) > 0.0
    assert float(ga.sum()) == pytest.approx((2 * terrain.EXTENT) ** 2, rel=1e-6)
    assert float(sa.sum() + ga.sum()) == pytest.approx((2 * meshes.SKIRT_OUTER) ** 2, rel=1e-6)


def test_the_far_lands_blocks_are_its_triangles_in_ranges_each_within_its_sphere():
    """The scene pass culls the far land by blocks: their ranges follow each other and
    cover its triangles once, and each block's sphere holds every one of its vertices (a
    vertex outside would be culled while in view). Within SKIRT_NEAR the grid is
    SKIRT_STEP apart: the land round any allowed eye follows the height field."""
    verts, blocks = meshes._far_skirt()
    first, count = blocks[:, 0].astype(int), blocks[:, 1].astype(int)
    assert first[0] == 0 and int(count.sum()) == len(verts)
    assert np.array_equal(first[1:], first[:-1] + count[:-1])
    assert int((count % 3).max()) == 0
    for a, n, cx, cy, cz, radius in blocks:
        p = verts[int(a):int(a + n), :3].astype(np.float64)
        assert float(np.linalg.norm(p - [cx, cy, cz], axis=1).max()) <= radius * (1 + 1e-6) + 1e-3
    xs = meshes.skirt_coordinates()
    near = xs[np.abs(xs) <= meshes.SKIRT_NEAR + 1e-6]
    assert float(np.diff(near).max()) <= meshes.SKIRT_STEP * 1.06   # the kept grid lines: 14 or 15 of 287
    assert float(near.max()) >= 3.0 * terrain.EXTENT


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


def _levels(m, k: int):
    """Chunk k's (cells, skirt) index arrays at each level of detail."""
    row = m.terrain_chunks[k].astype(int)
    f0, c0 = m.terrain_skirt0[k].astype(int)
    out = [(m.terrain_indices[row[0]:row[0] + row[1]], m.terrain_indices[f0:f0 + c0])]
    for level in range(1, len(meshes.LOD_STRIDES)):
        f, c = row[4 + 2 * level], row[5 + 2 * level]
        cut = c - int(m.terrain_skirts[k, level])
        out.append((m.terrain_indices[f:f + cut], m.terrain_indices[f + cut:f + c]))
    assert int(m.terrain_skirts[k, 0]) == len(out[0][1])
    return out


def test_every_level_of_detail_tiles_each_chunk_and_hangs_a_skirt_from_its_border():
    """At every level (meshes.LOD_STRIDES) each chunk's cells cover its square once (areas
    sum to it, none degenerate, all wound as the grid's) and are coarser than the level
    before; its skirt hangs from every edge of that level's outline, straight down to
    copies of the outline's vertices, all lowered by one depth, whose material (4) is the
    one the scene program never turns to face the eye."""
    m = meshes.build("countryside")
    n = meshes.TERRAIN_CELLS
    verts = m.terrain_vertices
    grid = n * n
    cell = 2 * terrain.EXTENT / (n - 1)
    fine_sign = np.sign(_signed_areas(verts, m.terrain_indices[:6]))[0]
    assert len(m.terrain_chunks) == meshes.CHUNKS ** 2
    for k in range(len(m.terrain_chunks)):
        levels = _levels(m, k)
        square = np.abs(_signed_areas(verts, levels[0][0])).sum()
        depths = set()
        for level, (cells, skirt) in enumerate(levels):
            areas = _signed_areas(verts, cells)
            assert bool(np.all(np.sign(areas) == fine_sign)) == True   # noqa: E712
            assert float(np.abs(areas).min()) > 0.49 * cell * cell   # half a grid cell at least
            assert float(np.abs(areas).sum()) == pytest.approx(float(square), rel=1e-6)
            if level:
                assert len(cells) < len(levels[level - 1][0])
            tri = skirt.reshape(-1, 3).astype(np.int64)
            low = tri[:, 2]
            assert bool(np.all(low >= grid)) and bool(np.all(tri[:, 0] < grid)) == True   # noqa: E712
            assert bool(np.all(verts[low, 9] == meshes.SKIRT_MATERIAL)) == True   # noqa: E712
            tops = {tuple(sorted(e)) for e in tri[0::2, :2].tolist()}
            assert tops == _border_edges(cells)
            # each lowered vertex under its own grid vertex: the one it pairs with
            for top, lowered in ((tri[0::2, 1], tri[0::2, 2]), (tri[1::2, 0], tri[1::2, 2])):
                assert np.array_equal(verts[top][:, [0, 2]], verts[lowered][:, [0, 2]])
                assert np.array_equal(verts[top][:, 3:6], verts[lowered][:, 3:6])
                depths |= set(np.round(verts[top, 1] - verts[lowered, 1], 4).tolist())
        assert len(depths) == 1 and min(depths) > 0.0


def _chunk_at(x: float, z: float) -> int:
    n = meshes.TERRAIN_CELLS
    i = int(round((x + terrain.EXTENT) / (2 * terrain.EXTENT) * (n - 1)))
    j = int(round((z + terrain.EXTENT) / (2 * terrain.EXTENT) * (n - 1)))
    for k, (i0, i1, j0, j1) in enumerate(meshes._chunk_ranges(n)):
        if i0 <= i < i1 and j0 <= j < j1:
            return k
    raise AssertionError((x, z))


def test_a_skirt_reaches_below_its_neighbour_at_any_two_levels():
    """Where two chunks meet, at every grid vertex of their shared border and for every two
    levels they may be drawn at, the height of each side's cells there (found by search in
    world coordinates): the higher side's skirt reaches at least down to the lower side,
    so no crack opens between them. Checked across the river, where the levels differ most."""
    m = meshes.build("countryside")
    n = meshes.TERRAIN_CELLS
    verts = m.terrain_vertices
    ranges = meshes._chunk_ranges(n)
    side = meshes.CHUNKS
    pairs = []
    for z in (-150.0, 0.0, 60.0):
        k = _chunk_at(float(terrain.river_x(z)), z)
        pairs += [(k, k + 1), (k, k + side)]   # the neighbour in +x, in +z
    for a, b in pairs:
        ai0, ai1, aj0, aj1 = ranges[a]
        if b == a + 1:
            border = [aj * n + ai1 for aj in range(aj0, aj1 + 1)]
        else:
            border = [aj1 * n + ai for ai in range(ai0, ai1 + 1)]
        la, lb = _levels(m, a), _levels(m, b)
        depth = {}
        for k, lv in ((a, la), (b, lb)):
            tri = lv[0][1].reshape(-1, 3).astype(np.int64)
            depth[k] = float(verts[tri[0, 1], 1] - verts[tri[0, 2], 1])
        for ca, _ in la:
            ha = np.array([_plane_height_at(verts, ca, float(verts[g, 0]), float(verts[g, 2])) for g in border])
            for cb, _ in lb:
                hb = np.array([_plane_height_at(verts, cb, float(verts[g, 0]), float(verts[g, 2])) for g in border])
                assert float((ha - hb).max()) <= depth[a]
                assert float((hb - ha).max()) <= depth[b]
    # the check has teeth: across the river the coarsest levels step by more than a metre
    assert float(m.terrain_lod_error[_chunk_at(float(terrain.river_x(0.0)), 0.0)].max()) > 1.0


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
    smooth = _chunk_at(-200.0, -200.0)
    river = _chunk_at(float(terrain.river_x(0.0)), 0.0)
    south = _chunk_at(float(terrain.river_x(-60.0)), -60.0)
    for k in (0, river, south):   # a corner; the river and the road; the river south of the road
        i0, i1, j0, j1 = ranges[k]
        I, J = np.meshgrid(np.arange(i0, i1 + 1), np.arange(j0, j1 + 1), indexing="xy")
        grid = (J * n + I).ravel()
        for level, (coarse, _) in enumerate(_levels(m, k)):
            if level == 0:
                continue
            gap = max(abs(_plane_height_at(verts, coarse, float(verts[g, 0]), float(verts[g, 2]))
                          - float(verts[g, 1])) for g in grid)
            assert m.terrain_lod_error[k, level] == pytest.approx(gap, abs=1e-5)
    # where the ground is smooth, the coarse levels are close; across the river, not
    assert m.terrain_lod_error[smooth, 2] < 0.1 and m.terrain_lod_error[river, 2] > 0.3


def _points_on(tris: np.ndarray, k: int = 6) -> np.ndarray:
    """Points on triangles (N, 3, 3): a barycentric grid of k steps on each, corners and
    edge midpoints among them."""
    u, v = np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij")
    keep = u + v <= k
    u, v = u[keep] / k, v[keep] / k
    a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
    return (a[:, None] + u[None, :, None] * (b - a)[:, None] + v[None, :, None] * (c - a)[:, None]).reshape(-1, 3)


def _segment_distance(p, a, b):
    ab = b - a
    t = np.clip(np.einsum("...i,...i->...", p - a, ab) / np.einsum("...i,...i->...", ab, ab), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[..., None] * ab), axis=-1)


def _distance_to_mesh(points: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Each point's exact distance (float64) to the nearest of the triangles (M, 3, 3): to
    its plane where the foot falls inside, else to its nearest edge."""
    p = points[:, None, :]
    a, b, c = (tris[None, :, i] for i in range(3))
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    h = np.einsum("...i,...i->...", p - a, n)
    foot = p - h[..., None] * n
    inside = np.ones(h.shape, bool)
    for q, r in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("...i,...i->...", np.cross(r - q, foot - q), n) >= 0.0
    d = np.where(inside, np.abs(h), np.inf)
    for q, r in ((a, b), (b, c), (c, a)):
        d = np.minimum(d, _segment_distance(p, q, r))
    return d.min(axis=1)


def test_a_coarse_tree_lies_within_its_groups_gap_of_the_full_one():
    """Every tree's coarse mesh against its full one, both ways: points on one surface to
    the other, exactly, within the tree's stored gap, itself within its group's; the gap
    no bound of several times too much."""
    m = meshes.build("countryside")
    worst = 0.0
    for x, z, full, coarse, gap in meshes._trees():
        assert gap <= float(m.object_groups[:, 8].max())
        f = full[:, :3].astype(np.float64).reshape(-1, 3, 3)
        c = coarse[:, :3].astype(np.float64).reshape(-1, 3, 3)
        d = max(float(_distance_to_mesh(_points_on(f), c).max()), float(_distance_to_mesh(_points_on(c), f).max()))
        assert d <= gap + 1e-5
        worst = max(worst, d / gap)
    assert worst > 0.7


def test_the_tree_groups_tile_the_objects_at_each_detail():
    """The water, house and bridge come first, then each group's trees at full detail end
    to end (that prefix is the shadow map's), then each group coarse; every corner of a
    group inside its bounding sphere, and the coarse trees fewer."""
    m = meshes.build("countryside")
    g = m.object_groups.astype(np.float64)
    first, count, cfirst, ccount = (g[:, i].astype(int) for i in (0, 1, 6, 7))
    assert first[0] > 0 and np.array_equal(first[1:], first[:-1] + count[:-1])
    assert first[-1] + count[-1] == m.objects_full == cfirst[0]
    assert np.array_equal(cfirst[1:], cfirst[:-1] + ccount[:-1])
    assert cfirst[-1] + ccount[-1] == len(m.objects)
    assert int(count.sum()) == sum(len(t[2]) for t in meshes._trees())
    assert int(ccount.sum()) < 0.5 * int(count.sum())
    for row in g:
        for a, n in ((int(row[0]), int(row[1])), (int(row[6]), int(row[7]))):
            p = m.objects[a:a + n, :3].astype(np.float64)
            assert float(np.linalg.norm(p - row[2:5], axis=1).max()) <= row[5] + 1e-4


def test_the_far_lands_skirt_reaches_below_every_edge_chunk_at_any_level():
    """On the detailed square's edge the far land has the grid's own heights. Where an edge
    chunk's cells (at any level, found by search) run below them, the far land's inner
    skirt reaches below the cells; where above, the chunk's own skirt reaches the grid.
    Checked where the river crosses the square's north and south edges, and at a corner."""
    m = meshes.build("countryside")
    n = meshes.TERRAIN_CELLS
    verts = m.terrain_vertices
    ranges = meshes._chunk_ranges(n)
    f, c = m.terrain_far_skirt
    tri = m.terrain_indices[f:f + c].reshape(-1, 3).astype(np.int64)
    assert len(tri) == 2 * 4 * (n - 1)   # two triangles down from every segment of the edge
    far_depth = set(np.round(verts[tri[:, 1], 1] - verts[tri[:, 2], 1], 4)[0::2].tolist())
    assert len(far_depth) == 1
    far_depth = far_depth.pop()
    E = terrain.EXTENT
    worst = 0.0
    for x, z in ((float(terrain.river_x(-E)), -E), (float(terrain.river_x(E)), E), (-E, -E)):
        k = _chunk_at(min(x, E - 1.0), min(z, E - 1.0))
        i0, i1, j0, j1 = ranges[k]
        border = sorted({j * n + i for i in range(i0, i1 + 1) for j in range(j0, j1 + 1)
                         if i in (0, n - 1) or j in (0, n - 1)})
        levels = _levels(m, k)
        own = levels[0][1].reshape(-1, 3).astype(np.int64)
        own_depth = float(verts[own[0, 1], 1] - verts[own[0, 2], 1])
        for cells, _ in levels:
            h = np.array([_plane_height_at(verts, cells, float(verts[g, 0]), float(verts[g, 2])) for g in border])
            step = verts[border, 1].astype(np.float64) - h
            assert float(step.max()) <= far_depth
            assert float(-step.min()) <= own_depth
            worst = max(worst, float(step.max()))
    assert worst > 0.05   # the coarse levels do run below the grid there


@pytest.mark.parametrize("level", range(len(meshes.LOD_STRIDES)))
def test_the_terrain_at_one_level_tiles_the_plane_without_a_crack(level):
    """meshes.terrain_at_level, what a coarse shadow map is drawn from: projected onto the
    ground, its triangles cover the square of side 2 SKIRT_OUTER once (areas sum to it);
    inside the detailed square every edge of the chunks' cells is shared by two triangles
    (neighbours meet border to border, no crack for light to leak through), so the edges
    used once all lie on that square's border; and it has fewer triangles than the level
    before."""
    m = meshes.build("countryside")
    E = terrain.EXTENT
    idx = meshes.terrain_at_level(m, level)
    area = np.abs(_signed_areas(m.terrain_vertices, idx)).sum()
    assert float(area) == pytest.approx((2 * meshes.SKIRT_OUTER) ** 2, rel=1e-6)
    cells = idx[:len(idx) - m.terrain_far[1] - m.terrain_far_skirt[1]]
    xz = m.terrain_vertices[:, [0, 2]].astype(np.float64)
    open_edges = np.array(sorted(_border_edges(cells)))
    on_border = np.isclose(np.abs(xz[open_edges]), E, atol=1e-3).any(axis=2).all(axis=1)
    assert int((~on_border).sum()) == 0
    if level:
        assert len(idx) < len(meshes.terrain_at_level(m, level - 1))


def test_the_house_stands_on_a_terrace_not_a_plinth():
    """A fresh eye saw a grey block under the house in every view of it: on its slope the
    ground under its corners fell 5.1 m from one to another (6.1 m over its footprint and a
    metre round it), and the plinth stood 5.2 m (plus 0.4 m sunk) out of the lowest. The
    ground under its footprint and a metre round it now lies within 5 cm of one level (the
    terrace), and its plinth is 0.5 m from bottom to top."""
    from fogbank.scene import terrain
    from fogbank.scene.landmarks import HOUSE
    from fogbank.scene.meshes import _house
    hx, hz = HOUSE
    x, z = np.meshgrid(np.linspace(hx - 6.0, hx + 6.0, 25), np.linspace(hz - 4.6, hz + 4.6, 19))
    ground = terrain.height(x, z)
    assert float(ground.max() - ground.min()) <= 0.05
    plinth = _house()[0]
    assert abs(float(plinth[:, 1].max() - plinth[:, 1].min()) - 0.5) <= 1e-4
