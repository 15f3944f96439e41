"""The sunlight that reaches each of Fischer's particles, in float64: through the fog's
density layers toward the sun (their references, the closed forms the shader takes) and
through the other particles (Fischer's clarity of each along the particle's ray toward
the sun), so that a swarm shades itself and smoke is dark where it is thick. The scene's
shadow on a particle is looked up on the GPU (render/shaders/passes/particles.vert).

Unitless, in [0, 1]: the share of the sun's light at the particle's centre. A particle's
own clarity is left out (its centre is its densest point: it would shade itself to
1 - alpha s)."""

from __future__ import annotations

import numpy as np

from fogbank.kinds.reference import density_optical_depth

# the pairwise distances are taken a block of particles at a time, each block's arrays
# (block x alive particles, float64) at most this many elements: 64 KiB, under the render
# worker's mmap threshold (workers/worker.py, 128 KiB), so that they come from the heap
# and not from a fresh mapping each frame (at 256 x all, 130 alive particles of smoke made
# 131 KiB arrays: 232 page faults a frame, tests/gl/test_output.py)
BLOCK_ELEMENTS = 8192


def particle_light(fog, packed, ref, time: float, sun_dir, sun_distance: float) -> np.ndarray:
    """(MAX_PARTICLES,) float32: each packed particle's share of the sunlight (the rows of
    packed.particles, positions relative to `ref`), 1 for rows without a particle.
    `sun_distance` (m): how far toward the sun the fog is integrated."""
    out = np.ones(len(packed.particles), np.float32)
    swarms = [v for k, v in zip(packed.kinds, packed.values) if k == "particles" and v["count"] >= 1]
    if not swarms:
        return out
    rows = np.concatenate([np.arange(int(v["first"]), int(v["first"] + v["count"])) for v in swarms])
    alpha = np.concatenate([np.full(int(v["count"]), float(v["alpha"])) for v in swarms])
    radius = packed.radii[rows].astype(np.float64)
    data = packed.particles[rows].astype(np.float64)
    pos = data[:, :3] + np.asarray(ref, dtype=np.float64)
    strength = data[:, 3]
    L = np.asarray(sun_dir, dtype=np.float64)
    n = len(rows)
    tau = density_optical_depth(fog, pos, np.broadcast_to(L, (n, 3)), np.full(n, sun_distance),
                                np.full(n, time))
    log_clear = np.zeros(n)
    alive = np.flatnonzero(strength > 0)
    # every ray runs along L for sun_distance, so the distance from particle j to row i's
    # ray follows from dot products: with rel = p_j - p_i, s = rel.L and u = clamp(s, 0,
    # sun_distance), |rel - u L|^2 = |rel|^2 - 2 u s + u^2 (Bourke's closest point, as
    # kinds/particles.py segment_distance, without its (rows, alive, 3) arrays). Positions
    # are taken from the swarm's mean: the rows' |p|^2 then stay near the swarm's size
    # squared, and |rel|^2 = |p_i|^2 + |p_j|^2 - 2 p_i.p_j keeps about 1e-12 of it
    centred = pos - pos[alive].mean(axis=0) if len(alive) else pos
    cols = centred[alive]
    s_cols, sq_cols = cols @ L, np.einsum("ij,ij->i", cols, cols)
    s_rows, sq_rows = centred @ L, np.einsum("ij,ij->i", centred, centred)
    opacity_at_centre = alpha[alive] * strength[alive]
    inv_radius = 1.0 / radius[alive]
    block = max(1, BLOCK_ELEMENTS // max(1, len(alive)))
    for lo in range(0, n, block):
        hi = min(n, lo + block)
        proj = s_cols[None, :] - s_rows[lo:hi, None]
        u = np.clip(proj, 0.0, sun_distance)
        d2 = sq_cols[None, :] + sq_rows[lo:hi, None] - 2.0 * (centred[lo:hi] @ cols.T) + u * (u - 2.0 * proj)
        dist = np.sqrt(np.maximum(d2, 0.0))
        opacity = np.minimum(opacity_at_centre[None, :] * np.clip(1.0 - dist * inv_radius[None, :], 0.0, 1.0),
                             1.0 - 1e-12)
        # a particle's own clarity is left out (the module's docstring)
        mine = np.flatnonzero((alive >= lo) & (alive < hi))
        opacity[alive[mine] - lo, mine] = 0.0
        log_clear[lo:hi] = np.log1p(-opacity).sum(axis=1)
    out[rows] = np.exp(-tau + max(fog.density, 0.0) * log_clear)
    return out
