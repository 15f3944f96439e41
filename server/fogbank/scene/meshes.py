"""Deterministic procedural scenes as vertex arrays (numpy, no GL).

Vertex layout: position (3), normal (3), albedo in linear RGB (3), material (1):
0 = vertex colour, 1 = terrain (albedo made in the shader), 2 = water, 3 = unlit,
4 = a terrain chunk's skirt (_skirt).

"countryside" is the seeds' kind of view: hills and a river valley, the river with a
bridge, a road over it, a house, a forest. "calibration" is a flat ground plane and
boxes of known colours, unlit, for tests that check colours exactly.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from fogbank.scene import terrain
from fogbank.scene.landmarks import HOUSE, tree_spots
from fogbank.model.fields import srgb_to_linear

VERTEX_FLOATS = 10
CHUNKS = 16   # terrain chunks per side (18 grid cells, the last 17)
TERRAIN_CELLS = 288   # vertices per side of the detailed grid
LOD_STRIDES = (1, 2, 4, 8, 16)   # a chunk's levels of detail: grid cells per coarse cell side


@dataclass(frozen=True)
class Mesh:
    terrain_vertices: np.ndarray   # (N, 10) float32, indexed
    terrain_indices: np.ndarray    # (M,) uint32, chunk after chunk, then the far land
    terrain_chunks: np.ndarray     # (K, 6 + 2 (levels - 1)): first index and count of its cells
                                   # at full detail, centre x, y, z, radius (m), then each coarser
                                   # level's (LOD_STRIDES) first index and count: cells, then skirt
    objects: np.ndarray            # (K, 10) float32, plain triangles
    bounds: tuple[np.ndarray, float]  # centre and half-size, for the shadow map
    terrain_far: tuple[int, int] = (0, 0)   # first index and count of the far land (the skirt)
    terrain_lod_error: np.ndarray | None = None   # (K, len(LOD_STRIDES)) m: each chunk's
                                   # vertical error at each level of detail (lod_errors)
    terrain_skirt0: np.ndarray | None = None   # (K, 2): first index and count of the skirt at full detail
    terrain_skirts: np.ndarray | None = None   # (K, len(LOD_STRIDES)): each level's skirt, indices
    objects_full: int = -1         # the objects' corners at full detail, from the first (-1: all)
    object_groups: np.ndarray | None = None   # (G, 9): the trees by chunk (_objects)
    terrain_far_skirt: tuple[int, int] = (0, 0)   # first index and count of the far land's inner skirt
    terrain_far_blocks: np.ndarray | None = None   # (B, 6): the far land in blocks (_far_skirt),
                                   # first index, count, centre x, y, z, radius (m)

    @property
    def full_detail(self) -> int:
        """How many of terrain_indices are the terrain at full detail (the grid's chunks, then
        the far land); the coarser levels of the chunks follow."""
        return self.terrain_far[0] + self.terrain_far[1]


def indexed(tris: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Plain triangles (N, VERTEX_FLOATS) as unique vertices and indices, the triangles in
    their order. A vertex shared by triangles (a smooth crown's, a box's edge within a face)
    is then shaded once: llvmpipe shades a plain triangle list's every corner, and the
    objects' 28k corners are 12k vertices."""
    verts, idx = np.unique(tris, axis=0, return_inverse=True)
    return verts.astype(np.float32), idx.reshape(-1).astype(np.uint32)


def _rgb(hex_: str) -> np.ndarray:
    return np.array(srgb_to_linear(hex_))


def _tris(pos: np.ndarray, nrm: np.ndarray, color, material: float) -> np.ndarray:
    out = np.zeros((len(pos), VERTEX_FLOATS), np.float32)
    out[:, 0:3], out[:, 3:6] = pos, nrm
    out[:, 6:9] = np.broadcast_to(np.asarray(color, dtype=np.float64), (len(pos), 3))
    out[:, 9] = material
    return out


def _quad(a, b, c, d, color, material=0.0) -> np.ndarray:
    """Two triangles a-b-c, a-c-d with the flat normal of (b - a) x (c - a)."""
    pos = np.array([a, b, c, a, c, d], dtype=np.float64)
    n = np.cross(np.subtract(b, a), np.subtract(c, a))
    n = n / np.linalg.norm(n)
    return _tris(pos, np.tile(n, (6, 1)), color, material)


def box(lo, hi, color, material=0.0) -> np.ndarray:
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    faces = [
        ((x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)),  # +z
        ((x1, y0, z0), (x0, y0, z0), (x0, y1, z0), (x1, y1, z0)),  # -z
        ((x1, y0, z1), (x1, y0, z0), (x1, y1, z0), (x1, y1, z1)),  # +x
        ((x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)),  # -x
        ((x0, y1, z1), (x1, y1, z1), (x1, y1, z0), (x0, y1, z0)),  # +y
        ((x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)),  # -y
    ]
    return np.concatenate([_quad(*f, color, material) for f in faces])


def cone(base, radius, height, color, segments=14) -> np.ndarray:
    """A cone with smooth side normals (tree crowns), open bottom."""
    bx, by, bz = base
    a = np.linspace(0, 2 * np.pi, segments + 1)
    ring = np.stack([bx + radius * np.cos(a), np.full_like(a, by), bz + radius * np.sin(a)], 1)
    tip = np.array([bx, by + height, bz])
    slope = radius / height
    nrm = np.stack([np.cos(a), np.full_like(a, slope), np.sin(a)], 1)
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    pos, nn = [], []
    for i in range(segments):
        mid = (nrm[i] + nrm[i + 1]) / 2
        pos += [ring[i + 1], ring[i], tip]
        nn += [nrm[i + 1], nrm[i], mid / np.linalg.norm(mid)]
    return _tris(np.array(pos), np.array(nn), color, 0.0)


def cylinder(base, radius, height, color, segments=8) -> np.ndarray:
    bx, by, bz = base
    a = np.linspace(0, 2 * np.pi, segments + 1)
    pos, nn = [], []
    for i in range(segments):
        c0, s0, c1, s1 = np.cos(a[i]), np.sin(a[i]), np.cos(a[i + 1]), np.sin(a[i + 1])
        p00 = (bx + radius * c0, by, bz + radius * s0)
        p10 = (bx + radius * c1, by, bz + radius * s1)
        p01 = (p00[0], by + height, p00[2])
        p11 = (p10[0], by + height, p10[2])
        n0, n1 = (c0, 0.0, s0), (c1, 0.0, s1)
        pos += [p10, p00, p01, p10, p01, p11]
        nn += [n1, n0, n0, n1, n0, n1]
    return _tris(np.array(pos), np.array(nn), color, 0.0)


def blob(center, radius, color, squash=0.85, subdivisions=2) -> np.ndarray:
    """A subdivided octahedron (a round crown for broadleaf trees), smooth normals."""
    v = [np.array(p, dtype=np.float64) for p in
         ((1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1))]
    faces = [(0, 2, 4), (4, 2, 1), (1, 2, 5), (5, 2, 0), (4, 3, 0), (1, 3, 4), (5, 3, 1), (0, 3, 5)]
    tris = [(v[a], v[b], v[c]) for a, b, c in faces]
    for _ in range(subdivisions):
        nxt = []
        for a, b, c in tris:
            ab, bc, ca = [(p + q) / np.linalg.norm(p + q) for p, q in ((a, b), (b, c), (c, a))]
            nxt += [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]
        tris = nxt
    unit = np.array([p for t in tris for p in t])
    scale = np.array([radius, radius * squash, radius])
    pos = np.asarray(center) + unit * scale
    nrm = unit / scale
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    return _tris(pos, nrm, color, 0.0)


def _terrain_grid(n: int = TERRAIN_CELLS):
    """The detailed terrain: vertices (n * n, 10), the indices of its chunks' cells, chunk
    after chunk, and the chunk table (K, 6): first index, count, bounding sphere."""
    xs = np.linspace(-terrain.EXTENT, terrain.EXTENT, n)
    X, Z = np.meshgrid(xs, xs, indexing="xy")
    Y = terrain.height(X, Z)
    N = terrain.normal(X, Z)
    verts = np.zeros((n * n, VERTEX_FLOATS), np.float32)
    verts[:, 0], verts[:, 1], verts[:, 2] = X.ravel(), Y.ravel(), Z.ravel()
    verts[:, 3:6] = N.reshape(-1, 3)
    verts[:, 9] = 1.0
    # cells in square chunks, so that the renderer can draw the nearest chunks first
    # (early depth rejection then skips most hidden terrain fragments)
    idx, chunks = [], []
    for i0, i1, j0, j1 in _chunk_ranges(n):
        tri = _chunk_indices(n, i0, i1, j0, j1, 1)
        first = sum(len(x) for x in idx)
        centre = verts[tri, :3].mean(axis=0)
        radius = np.linalg.norm(verts[tri, :3] - centre, axis=1).max()   # bounding sphere
        chunks.append((first, len(tri), *centre, radius))
        idx.append(tri)
    return verts, np.concatenate(idx).astype(np.uint32), np.array(chunks, dtype=np.float64)


def _chunk_ranges(n: int) -> list[tuple[int, int, int, int]]:
    """Each chunk's first and last vertex column and row (i0, i1, j0, j1), inclusive."""
    step = (n - 1) // CHUNKS + 1
    return [(i0, min(i0 + step, n - 1), j0, min(j0 + step, n - 1))
            for j0 in range(0, n - 1, step) for i0 in range(0, n - 1, step)]


def _lines(lo: int, hi: int, stride: int) -> list[int]:
    """Grid lines lo, lo + stride, ..., hi; no interval shorter than 2 (a short last one
    joins the one before), so that every coarse cell has a vertex strictly inside."""
    out = list(range(lo, hi, stride)) + [hi]
    if len(out) > 2 and out[-1] - out[-2] < 2:
        out.pop(-2)
    return out


def _chunk_indices(n: int, i0: int, i1: int, j0: int, j1: int, stride: int) -> np.ndarray:
    """Triangles of a chunk's cells at a level of detail: cells `stride` grid cells wide
    (_lines), two triangles each, wound as the grid's (a, c, b). A coarse chunk's border
    is at its own stride too; _skirt hides the cracks where it meets a finer one."""
    if stride == 1:
        xs, zs = np.arange(i0, i1 + 1), np.arange(j0, j1 + 1)
    else:
        xs, zs = np.array(_lines(i0, i1, stride)), np.array(_lines(j0, j1, stride))
    XA, ZA = np.meshgrid(xs[:-1], zs[:-1], indexing="xy")
    XB, ZB = np.meshgrid(xs[1:], zs[1:], indexing="xy")
    a, b, c, d = ZA * n + XA, ZA * n + XB, ZB * n + XA, ZB * n + XB
    return np.stack([a, c, b, b, c, d], -1).ravel().astype(np.int64)


def _ring(i0: int, i1: int, j0: int, j1: int, stride: int) -> list[tuple[int, int]]:
    """A chunk's border vertices (i, j) at a level of detail, once round, counterclockwise
    in (i, j) from (i0, j0)."""
    if stride == 1:
        xs, zs = list(range(i0, i1 + 1)), list(range(j0, j1 + 1))
    else:
        xs, zs = _lines(i0, i1, stride), _lines(j0, j1, stride)
    return ([(i, j0) for i in xs[:-1]] + [(i1, j) for j in zs[:-1]]
            + [(i, j1) for i in xs[:0:-1]] + [(i0, j) for j in zs[:0:-1]])


# A chunk's skirt (Ulrich 2002, "Rendering massive terrains using chunked level of
# detail control"): a strip hanging from its border, straight down by the chunk's
# SKIRT depth. Chunks drawn at different levels do not share their border's vertices;
# where a border runs above its neighbour's, its skirt fills the step between them.
# Below the ground it is hidden from any eye above the ground (render/passes/scene.py
# draws none for an eye below it). Its lower vertices are material 4, which the scene
# program never turns to face the eye (passes/scene.frag): it is shaded as the border.
SKIRT_MATERIAL = 4.0
SKIRT_MARGIN = 0.05   # m below the largest step the chunk can meet


def skirt_depths(errors: np.ndarray) -> np.ndarray:
    """Each chunk's skirt depth (m) from every chunk's vertical error (K, levels), chunks
    row by row as _chunk_ranges: along a shared border both sides lie within their own
    error of the grid, and the step between them is largest at a grid vertex, so it is at
    most the chunk's largest error plus its largest neighbour's (the far land's border is
    the grid's own)."""
    worst = errors.max(axis=1)
    side = int(round(np.sqrt(len(worst))))
    w = worst.reshape(side, side)
    nb = np.zeros_like(w)
    nb[1:, :] = np.maximum(nb[1:, :], w[:-1, :])
    nb[:-1, :] = np.maximum(nb[:-1, :], w[1:, :])
    nb[:, 1:] = np.maximum(nb[:, 1:], w[:, :-1])
    nb[:, :-1] = np.maximum(nb[:, :-1], w[:, 1:])
    return (w + nb).ravel() + SKIRT_MARGIN


def _lowered(verts: np.ndarray, n: int, ring: list[tuple[int, int]], depth: float,
             first: int) -> tuple[dict[tuple[int, int], int], list[np.ndarray]]:
    """Copies of the ring's grid vertices `depth` (m) lower, material SKIRT_MATERIAL,
    numbered from `first`: (their index by (i, j), the rows)."""
    rows = []
    for i, j in ring:
        v = verts[j * n + i].copy()
        v[1] -= depth
        v[9] = SKIRT_MATERIAL
        rows.append(v)
    return {p: first + k for k, p in enumerate(ring)}, rows


def _skirt(n: int, ring: list[tuple[int, int]], lower: dict[tuple[int, int], int]) -> np.ndarray:
    """Two triangles down from each segment p-q of the ring to the lowered copies p', q'
    (vertex indices in `lower`): (p, q, q') and (p, q', p'), the last vertex (GL's
    provoking vertex, which gives a flat varying its value) a lowered one."""
    tris = []
    for k in range(len(ring)):
        p, q = ring[k], ring[(k + 1) % len(ring)]
        tp, tq = p[1] * n + p[0], q[1] * n + q[0]
        tris += [tp, tq, lower[q], tp, lower[q], lower[p]]
    return np.array(tris, dtype=np.int64)


def _terrain_lods(verts: np.ndarray, n: int, first: int):
    """Every chunk's levels of detail with their skirts, as indices from `first` on, chunk
    after chunk: level 0's skirt (its cells are the full-detail block's), then each coarser
    level's cells and skirt. Returns the indices, the table (K, 2 (levels - 1)) of each
    coarser level's first index and count (cells then skirt), level 0's skirt (K, 2), each
    level's skirt index count (K, levels), the errors (K, levels; lod_errors of the
    cells) and the lowered vertices (rows of `verts`' layout, numbered from len(verts))."""
    ranges = _chunk_ranges(n)
    cells = [[_chunk_indices(n, *rg, s) for s in LOD_STRIDES] for rg in ranges]
    errors = np.array([[0.0] + [lod_errors(verts, c) for c in row[1:]] for row in cells])
    depth = skirt_depths(errors)
    idx, table, skirt0, skirt_counts, lowered = [], [], [], [], []
    at, next_vertex = first, len(verts)
    for k, rg in enumerate(ranges):
        ring = _ring(*rg, 1)
        lower, rows = _lowered(verts, n, ring, depth[k], next_vertex)
        next_vertex += len(rows)
        lowered += rows
        row, counts = [], []
        for level, stride in enumerate(LOD_STRIDES):
            skirt = _skirt(n, _ring(*rg, stride), lower)
            part = skirt if level == 0 else np.concatenate([cells[k][level], skirt])
            if level == 0:
                skirt0.append((at, len(part)))
            else:
                row += [at, len(part)]
            counts.append(len(skirt))
            idx.append(part)
            at += len(part)
        table.append(row)
        skirt_counts.append(counts)
    return (np.concatenate(idx).astype(np.uint32), np.array(table, dtype=np.float64),
            np.array(skirt0, dtype=np.float64), np.array(skirt_counts, dtype=np.int64), errors,
            np.array(lowered, dtype=np.float32))


def terrain_at_level(mesh: Mesh, level: int) -> np.ndarray:
    """The terrain's indices with every chunk at one level of detail (LOD_STRIDES[level]),
    then the far land and its inner skirt: what a coarse shadow map is drawn from
    (render/passes/shadow.py). No chunk's skirt: chunks at one level meet border to border
    (a shared border is cut at the same grid lines from both sides, _lines); the far
    land's inner skirt fills the step between its edge, the full grid's, and a coarse
    edge chunk's."""
    table = mesh.terrain_chunks
    parts = []
    for k, row in enumerate(table):
        if level == 0:
            first, count = int(row[0]), int(row[1])
        else:
            first, count = int(row[4 + 2 * level]), int(row[5 + 2 * level]) - int(mesh.terrain_skirts[k, level])
        parts.append(mesh.terrain_indices[first:first + count])
    for first, count in (mesh.terrain_far, mesh.terrain_far_skirt):
        parts.append(mesh.terrain_indices[first:first + count])
    return np.concatenate(parts)


def lod_errors(verts: np.ndarray, indices: np.ndarray, n: int = TERRAIN_CELLS) -> float:
    """The vertical error (m) of grid triangles against the full-detail grid: the largest
    |height of the triangles - height of the grid vertex| over the grid vertices they
    cover. Each triangle's corners are grid vertices, so it is solved in grid units (i, j):
    every grid point of its bounding window, by barycentric coordinates (exact in float64
    for integer points; 1e-9 keeps its edges inside), inside it or not."""
    tri = indices.reshape(-1, 3).astype(np.int64)
    if len(tri) == 0:
        return 0.0
    h = verts[:, 1].astype(np.float64)
    I, J = tri % n, tri // n
    i0, j0 = I.min(1, keepdims=True), J.min(1, keepdims=True)
    side = int(max((I.max(1, keepdims=True) - i0).max(), (J.max(1, keepdims=True) - j0).max())) + 1
    a, b = (g.ravel()[None] for g in np.meshgrid(np.arange(side), np.arange(side), indexing="xy"))
    pi, pj = np.minimum(i0 + a, n - 1), np.minimum(j0 + b, n - 1)
    x1, y1 = I[:, 1:2] - I[:, 0:1], J[:, 1:2] - J[:, 0:1]
    x2, y2 = I[:, 2:3] - I[:, 0:1], J[:, 2:3] - J[:, 0:1]
    px, py = pi - I[:, 0:1], pj - J[:, 0:1]
    det = (x1 * y2 - x2 * y1).astype(np.float64)   # never 0: no triangle is degenerate
    u, v = (px * y2 - x2 * py) / det, (x1 * py - px * y1) / det
    inside = (u >= -1e-9) & (v >= -1e-9) & (u + v <= 1.0 + 1e-9)
    H = h[tri]
    plane = H[:, 0:1] + u * (H[:, 1:2] - H[:, 0:1]) + v * (H[:, 2:3] - H[:, 0:1])
    return float(np.where(inside, np.abs(plane - h[pj * n + pi]), 0.0).max())


def _house() -> list[np.ndarray]:
    hx, hz = HOUSE
    w, dpt, wall_h = 5.0, 3.6, 4.2
    corners = [terrain.height(hx + sx * w, hz + sz * dpt) for sx in (-1, 1) for sz in (-1, 1)]
    y0 = float(min(corners)) - 0.4
    floor = float(max(corners)) + 0.1
    wall = _rgb("#d9d2c3")
    roof = _rgb("#7a2b1e")
    parts = [box((hx - w - 0.2, y0, hz - dpt - 0.2), (hx + w + 0.2, floor, hz + dpt + 0.2), _rgb("#6f6a62")),
             box((hx - w, floor, hz - dpt), (hx + w, floor + wall_h, hz + dpt), wall)]
    top, ridge = floor + wall_h, floor + wall_h + 2.8
    ov = 0.6
    xa, xb = hx - w - ov, hx + w + ov
    za, zb = hz - dpt - ov, hz + dpt + ov
    parts += [_quad((xa, top, zb), (xb, top, zb), (xb, ridge, hz), (xa, ridge, hz), roof),
              _quad((xb, top, za), (xa, top, za), (xa, ridge, hz), (xb, ridge, hz), roof),
              _quad((xa, top - 0.05, za), (xb, top - 0.05, za), (xb, top - 0.05, zb), (xa, top - 0.05, zb), roof * 0.6)]
    # gables
    for x, sgn in ((hx - w, -1), (hx + w, 1)):
        tri = np.array([(x, top, hz - dpt), (x, top, hz + dpt), (x, ridge - 0.3, hz)])
        if sgn < 0:
            tri = tri[::-1]
        parts.append(_tris(tri, np.tile((sgn, 0.0, 0.0), (3, 1)), wall, 0.0))
    # door and windows, 4 cm proud of the wall (well above depth precision at 100 m)
    zf = hz + dpt + 0.04
    dark = _rgb("#2a3440")
    parts.append(box((hx - 0.6, floor, zf - 0.05), (hx + 0.6, floor + 2.2, zf), _rgb("#5b3a22")))
    for cx in (hx - 3.0, hx + 3.0):
        parts.append(box((cx - 0.7, floor + 1.3, zf - 0.05), (cx + 0.7, floor + 2.6, zf), dark))
    for cx in (hx - 2.5, hx + 2.5):
        parts.append(box((cx - 0.7, floor + 1.3, hz - dpt - 0.04), (cx + 0.7, floor + 2.6, hz - dpt + 0.01), dark))
    parts.append(box((hx + 2.2, top, hz - 1.2), (hx + 3.1, ridge + 0.6, hz - 0.3), _rgb("#8a5a44")))
    return parts


def _bridge() -> list[np.ndarray]:
    bx = float(terrain.river_x(terrain.ROAD_Z))
    z0 = terrain.ROAD_Z
    half = 13.0
    deck = terrain.BRIDGE_DECK
    stone = _rgb("#8d877c")
    wood = _rgb("#6b4a2f")
    parts = [box((bx - half, deck - 0.5, z0 - 3.3), (bx + half, deck + 0.02, z0 + 3.3), stone)]
    for side in (-1, 1):
        zr = z0 + side * 3.15
        parts.append(box((bx - half, deck + 0.9, zr - 0.12), (bx + half, deck + 1.05, zr + 0.12), wood))
        for px in np.arange(bx - half + 0.5, bx + half, 2.0):
            parts.append(box((px - 0.1, deck, zr - 0.1), (px + 0.1, deck + 0.95, zr + 0.1), wood))
    for px in (bx - 5.0, bx + 5.0):
        parts.append(box((px - 0.8, -3.5, z0 - 2.6), (px + 0.8, deck - 0.5, z0 + 2.6), stone * 0.9))
    return parts


# A tree far enough away is drawn coarser (render/passes/scene.py): crowns and trunks with
# fewer sides. Both are inscribed in the same circles (spheres), so where they differ is
# within the coarse one's gap to its circle: r (1 - cos(pi / sides)) for a cone or
# cylinder, r (1 - the nearest face's distance from the centre) for the unit crown.
TREE_SIDES = {"cone": (14, 6), "cylinder": (8, 4), "blob": (2, 1)}   # (full, coarse); blob: subdivisions


def _blob_gap(subdivisions: int) -> float:
    """1 - the smallest distance from the centre to a face of the unit crown's mesh."""
    unit = blob((0.0, 0.0, 0.0), 1.0, (1.0, 1.0, 1.0), squash=1.0, subdivisions=subdivisions)[:, :3]
    a, b, c = unit[0::3].astype(np.float64), unit[1::3].astype(np.float64), unit[2::3].astype(np.float64)
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return float(1.0 - np.abs(np.einsum("ij,ij->i", n, a)).min())


def _trees() -> list[tuple[float, float, np.ndarray, np.ndarray, float]]:
    """Every tree: (x, z, triangles, coarse triangles, the coarse one's largest gap to the
    full one, m)."""
    out = []
    rng = np.random.default_rng(77)
    cone_gap = 1.0 - np.cos(np.pi / TREE_SIDES["cone"][1])
    trunk_gap = 1.0 - np.cos(np.pi / TREE_SIDES["cylinder"][1])
    for x, z, kind in tree_spots():
        y = float(terrain.height(x, z)) - 0.3
        s = rng.uniform(0.8, 1.25)
        trunk = _rgb("#4a3526")
        both = []
        if kind == "pine":
            green = _rgb("#1f3d1c") * rng.uniform(0.8, 1.15)
            crowns = [((x, y + (2.0 + 2.3 * k) * s, z), r * s, h * s)
                      for k, (r, h) in enumerate(((3.2, 5.5), (2.5, 4.5), (1.7, 3.6)))]
            for level in (0, 1):
                both.append(np.concatenate(
                    [cylinder((x, y, z), 0.35 * s, 3.0 * s, trunk, TREE_SIDES["cylinder"][level])]
                    + [cone(b, r, h, green, TREE_SIDES["cone"][level]) for b, r, h in crowns]))
            gap = max(0.35 * s * trunk_gap, 3.2 * s * cone_gap)
        else:
            green = _rgb("#3a5a22") * rng.uniform(0.8, 1.15)
            for level in (0, 1):
                both.append(np.concatenate(
                    [cylinder((x, y, z), 0.4 * s, 4.0 * s, trunk, TREE_SIDES["cylinder"][level]),
                     blob((x, y + 5.5 * s, z), 3.4 * s, green, subdivisions=TREE_SIDES["blob"][level])]))
            gap = max(0.4 * s * trunk_gap, 3.4 * s * _blob_gap(TREE_SIDES["blob"][1]))
        out.append((x, z, both[0], both[1], gap))
    return out


def _objects() -> tuple[np.ndarray, int, np.ndarray]:
    """The objects' triangles: the water, the house and the bridge, then the trees by
    terrain chunk (the ground's CHUNKS x CHUNKS squares), each group at full detail, then
    each group coarse. Also how many corners come before the coarse ones (the scene at
    full detail: the shadow map's) and the groups' table (G, 9): first corner and count at
    full detail, bounding sphere (centre x, y, z, radius; m), first corner and count
    coarse, and the largest gap of a coarse tree to its full one (m)."""
    E, F = terrain.EXTENT, SKIRT_OUTER
    water = _quad((-F, terrain.WATER_LEVEL, F), (F, terrain.WATER_LEVEL, F),
                  (F, terrain.WATER_LEVEL, -F), (-F, terrain.WATER_LEVEL, -F), _rgb("#0e2a30"), 2.0)
    fixed = np.concatenate([water] + _house() + _bridge())
    groups: dict[tuple[int, int], list] = {}
    for tree in _trees():
        cell = tuple(int(np.clip((c + E) / (2 * E) * CHUNKS, 0, CHUNKS - 1)) for c in tree[:2])
        groups.setdefault(cell, []).append(tree)
    full, coarse, table = [], [], []
    at = len(fixed)
    for cell in sorted(groups):
        trees = groups[cell]
        tris = np.concatenate([t[2] for t in trees])
        pts = np.concatenate([tris] + [t[3] for t in trees])[:, :3].astype(np.float64)   # either detail
        centre = (pts.min(axis=0) + pts.max(axis=0)) / 2
        table.append([at, len(tris), *centre, float(np.linalg.norm(pts - centre, axis=1).max()),
                      0, 0, max(t[4] for t in trees)])
        full.append(tris)
        at += len(tris)
    for row, cell in zip(table, sorted(groups)):
        tris = np.concatenate([t[3] for t in groups[cell]])
        row[6], row[7] = at, len(tris)
        coarse.append(tris)
        at += len(tris)
    objects = np.concatenate([fixed] + full + coarse)
    return objects, sum(len(x) for x in [fixed] + full), np.array(table, dtype=np.float64)


# The land beyond the detailed terrain, out to the horizon: the same height field on a
# grid: cells of SKIRT_STEP metres out to SKIRT_NEAR (beyond the camera's bounds, so the
# land under and round any allowed eye is within about 0.3 m of the height field: with
# 190 m cells the far land's facets rose up to 20 m above it, over an eye 3 m above the
# ground at the bounds' edge), then cells growing by SKIRT_GROWTH out to SKIRT_OUTER
# (within the camera's far plane). The cells along the edge are fans onto the detailed
# grid's own edge vertices, so the two meshes share every seam vertex: no crack, and no
# overlap for a coarse facet to poke through.
SKIRT_OUTER = 120000.0
SKIRT_GROWTH = 1.3
SKIRT_INNER_CELLS = 20   # coarse cells along each side of the detailed square (22 m)
SKIRT_STEP = 2 * terrain.EXTENT / SKIRT_INNER_CELLS
SKIRT_NEAR = 3.0 * terrain.EXTENT + 2 * SKIRT_STEP   # scene/bounds.py: the eye stays within 3 EXTENT


def _edge_lines() -> np.ndarray:
    """The detailed grid's lines along one side, and which of them the coarse grid keeps."""
    fine = np.linspace(-terrain.EXTENT, terrain.EXTENT, TERRAIN_CELLS)
    keep = np.round(np.linspace(0, TERRAIN_CELLS - 1, SKIRT_INNER_CELLS + 1)).astype(int)
    return fine, keep


def skirt_coordinates() -> np.ndarray:
    """The skirt's coarse grid lines along x (and z): some of the detailed grid's lines,
    then rings SKIRT_STEP apart to SKIRT_NEAR, then rings whose gaps grow outward."""
    ring, step = [terrain.EXTENT], SKIRT_STEP
    while ring[-1] < SKIRT_OUTER:
        if ring[-1] >= SKIRT_NEAR - 1e-6:
            step *= SKIRT_GROWTH
        ring.append(min(float(np.round(ring[-1] + step)), SKIRT_OUTER))   # whole metres: exact in float32
    fine, keep = _edge_lines()
    return np.concatenate([-np.array(ring[:0:-1]), fine[keep], np.array(ring[1:])])


FAR_BLOCK = 4   # the far land's cells per side of a block, culled by the view as one


def _far_skirt() -> tuple[np.ndarray, np.ndarray]:
    """The far land as terrain-material triangles, at the terrain's own height: every cell
    of the coarse grid outside the detailed square; a cell with a side on the square's
    edge is a fan from its outer corner onto the detailed grid's vertices along that side.
    The cells come in blocks of FAR_BLOCK x FAR_BLOCK, each a range the scene pass culls by
    the view: (N, 10) vertices, and per block (first vertex, count, centre x, y, z, radius)."""
    E = terrain.EXTENT
    fine, _ = _edge_lines()
    xs = skirt_coordinates()
    n = len(xs)

    def vertex(x, z):   # its height is filled in below, for all vertices at once
        return (x, 0.0, z)

    blocks: dict[tuple[int, int], list] = {}
    for j in range(n - 1):
        for i in range(n - 1):
            x0, x1, z0, z1 = xs[i], xs[i + 1], xs[j], xs[j + 1]
            if max(abs(x0), abs(x1)) <= E and max(abs(z0), abs(z1)) <= E:
                continue   # inside the detailed terrain
            tris = blocks.setdefault((j // FAR_BLOCK, i // FAR_BLOCK), [])
            a, b, c, d = vertex(x0, z0), vertex(x1, z0), vertex(x0, z1), vertex(x1, z1)
            on_edge = None
            if max(abs(z0), abs(z1)) <= E and (x1 == -E or x0 == E):      # left or right of it
                x = x1 if x1 == -E else x0
                far = (b, d) if x0 == E else (a, c)     # the side away from the square
                edge = [vertex(x, z) for z in fine if z0 <= z <= z1]
                on_edge = (edge, far)
            elif max(abs(x0), abs(x1)) <= E and (z1 == -E or z0 == E):    # in front or behind
                z = z1 if z1 == -E else z0
                far = (c, d) if z0 == E else (a, b)
                edge = [vertex(x, z) for x in fine if x0 <= x <= x1]
                on_edge = (edge, far)
            if on_edge is None:
                tris += [a, c, b, b, c, d]
                continue
            edge, (f0, f1) = on_edge
            for k in range(len(edge) - 1):              # the fan from the far side's first corner
                tris += [f0, edge[k], edge[k + 1]]
            tris += [f0, edge[-1], f1]
    parts, table, at = [], [], 0
    for key in sorted(blocks):
        pos = np.array(blocks[key], dtype=np.float64)
        pos[:, 1] = terrain.height(pos[:, 0], pos[:, 2])
        lo, hi = pos.min(axis=0), pos.max(axis=0)
        table.append((at, len(pos), *((lo + hi) / 2), float(np.linalg.norm(hi - lo) / 2)))
        parts.append(pos)
        at += len(pos)
    pos = np.concatenate(parts).reshape(-1, 3, 3)
    # wound as the grid's triangles, facing up: the fans on two of the square's sides came
    # out the other way, and the scene program shades a back face by its reversed normal
    # (a dark band of ground shaded from below along the detailed land's edge)
    up = np.cross(pos[:, 1] - pos[:, 0], pos[:, 2] - pos[:, 0])[:, 1] < 0
    pos[up, 1], pos[up, 2] = pos[up, 2].copy(), pos[up, 1].copy()
    pos = pos.reshape(-1, 3)
    return _tris(pos, terrain.normal(pos[:, 0], pos[:, 2]), (1.0, 1.0, 1.0), 1.0), np.array(table)


@lru_cache(maxsize=2)
def build(name: str) -> Mesh:
    if name == "calibration":
        return _calibration()
    tv, ti, tc = _terrain_grid()
    # the far land is terrain too (drawn by the terrain's program, baked in its lightmap):
    # its triangles follow the grid's in the vertex and index buffers
    skirt, far_blocks = _far_skirt()
    far = (len(ti), len(skirt))
    far_blocks[:, 0] += len(ti)
    ti = np.concatenate([ti, np.arange(len(tv), len(tv) + len(skirt), dtype=np.uint32)])
    tv = np.concatenate([tv, skirt])
    lod, table, skirt0, skirt_counts, err, lowered = _terrain_lods(tv, TERRAIN_CELLS, len(ti))
    ti = np.concatenate([ti, lod])
    tc = np.concatenate([tc, table], axis=1)
    tv = np.concatenate([tv, lowered])
    # the far land's inner edge is the full grid's: where a coarse edge chunk's border runs
    # below it, a skirt hanging from the far land's edge fills the step (by the edge
    # chunks' largest error; where the chunk's border runs above, its own skirt does)
    n = TERRAIN_CELLS
    edge = [k for k, (i0, i1, j0, j1) in enumerate(_chunk_ranges(n)) if min(i0, j0) == 0 or max(i1, j1) == n - 1]
    ring = _ring(0, n - 1, 0, n - 1, 1)
    lower, drop = _lowered(tv, n, ring, float(err[edge].max()) + SKIRT_MARGIN, len(tv))
    far_skirt = (len(ti), 6 * len(ring))
    ti = np.concatenate([ti, _skirt(n, ring, lower).astype(np.uint32)])
    tv = np.concatenate([tv, np.array(drop, dtype=np.float32)])
    E = terrain.EXTENT
    objects, objects_full, groups = _objects()
    return Mesh(tv, ti, tc, objects, (np.array([0.0, 5.0, 0.0]), E * 1.05), far, err, skirt0, skirt_counts,
                objects_full, groups, far_skirt, far_blocks)


# The calibration scene: unlit, so a pixel's scene colour equals its albedo exactly.
CALIBRATION_GROUND = "#808080"
CALIBRATION_SKY = "#9fb4cc"
CALIBRATION_BOXES = (  # (lo, hi, colour)
    ((-6.0, 0.0, -30.0), (-2.0, 4.0, -26.0), "#d02020"),
    ((2.0, 0.0, -50.0), (6.0, 6.0, -46.0), "#20b040"),
    ((-14.0, 0.0, -80.0), (-8.0, 10.0, -74.0), "#2040d0"),
    ((10.0, 0.0, -120.0), (18.0, 12.0, -112.0), "#f0f0f0"),
)


def _calibration() -> Mesh:
    E = 2000.0
    ground = _quad((-E, 0.0, E), (E, 0.0, E), (E, 0.0, -E), (-E, 0.0, -E), _rgb(CALIBRATION_GROUND), 3.0)
    boxes = [box(lo, hi, _rgb(c), 3.0) for lo, hi, c in CALIBRATION_BOXES]
    empty_v = np.zeros((0, VERTEX_FLOATS), np.float32)
    return Mesh(empty_v, np.zeros(0, np.uint32), np.zeros((0, 10)), np.concatenate([ground] + boxes),
                (np.array([0.0, 0.0, -60.0]), 150.0))
