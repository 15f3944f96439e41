"""Fractal Perlin noise baked on the CPU into a tiling 3D texture (Perlin fog write-up).

Octaves of periodic gradient noise are summed (each octave twice the frequency, half the
weight), blurred separably with binomial weights (a row of Pascal's triangle) wrapping
around the edges so the tile has no seams, and normalised to [0, 1]. Baked once per
(size, octaves, blur, seed) and cached.
"""

from __future__ import annotations

from functools import lru_cache
from math import comb

import numpy as np

BASE_CELLS = 4  # lattice cells per tile in the first octave


def _fade(t):
    return t * t * t * (t * (t * 6 - 15) + 10)  # Perlin 2002 quintic


def _corner_maps(size: int, cells: int) -> tuple[np.ndarray, np.ndarray]:
    """Along one axis, the linear maps from the lattice's `cells` gradients to the `size`
    texel centres: Q[i, a], the fade weight of lattice point a at texel i (its two
    neighbouring lattice points, wrapping), and P[i, a], that weight times the texel's
    offset from a (the gradient's dot product along this axis)."""
    p = (np.arange(size) + 0.5) * cells / size
    i0 = np.floor(p).astype(int)
    f = p - i0
    u = _fade(f)
    Q = np.zeros((size, cells))
    P = np.zeros((size, cells))
    rows = np.arange(size)
    for d in (0, 1):
        a = (i0 + d) % cells
        w = u if d else 1 - u
        np.add.at(Q, (rows, a), w)
        np.add.at(P, (rows, a), w * (f - d))
    return Q, P


def _perlin_octave(size: int, cells: int, rng: np.random.Generator) -> np.ndarray:
    """One octave of periodic gradient noise at the texel centres, float64:
    sum over the 8 lattice corners of fade(x) fade(y) fade(z) g . (offset). Each term is a
    product of one-axis factors (Q along two axes, P along the gradient component's own),
    so the sum is three tensor contractions of the lattice's gradients (numpy's einsum
    with BLAS): 128^3 texels of a 128^3 lattice in 0.3-0.5 s on one core here, where
    gathering the 8 corners' gradients for every texel took 2-3 s for each octave."""
    g = rng.normal(size=(cells, cells, cells, 3))
    g /= np.linalg.norm(g, axis=-1, keepdims=True)
    Q, P = _corner_maps(size, cells)
    out = np.zeros((size, size, size))
    for c, (A, B, C) in enumerate(((P, Q, Q), (Q, P, Q), (Q, Q, P))):
        # optimize=True contracts pairwise over BLAS; without it einsum loops over all six
        # indices at once (minutes at 128^3). BLAS may order the sums otherwise than the
        # gather did: the texels agree to ~3e-16 (tests/unit/test_noise_bake.py)
        out += np.einsum("ia,jb,kc,abc->ijk", A, B, C, g[..., c], optimize=True)
    return out


def binomial_blur(a: np.ndarray, order: int) -> np.ndarray:
    """Separable blur with weights C(order, i) / 2^order along each axis, wrapping around."""
    if order <= 0:
        return a
    w = np.array([comb(order, i) for i in range(order + 1)], dtype=np.float64) / 2.0**order
    for axis in range(a.ndim):
        acc = np.zeros_like(a)
        for i, wi in enumerate(w):
            acc += wi * np.roll(a, i - order // 2, axis=axis)
        a = acc
    return a


@lru_cache(maxsize=8)
def bake(size: int = 64, octaves: int = 4, blur: int = 2, seed: int = 7) -> np.ndarray:
    """The tiling noise texture, float32 in [0, 1], indexed [x, y, z]. Read-only."""
    rng = np.random.default_rng(seed)
    total = np.zeros((size, size, size))
    for o in range(octaves):
        cells = min(BASE_CELLS * 2**o, size)
        total += 0.5**o * _perlin_octave(size, cells, rng)
    total = binomial_blur(total, blur)
    lo, hi = total.min(), total.max()
    out = ((total - lo) / (hi - lo if hi > lo else 1.0)).astype(np.float32)
    out.setflags(write=False)
    return out


def sample(tex: np.ndarray, x: np.ndarray, scale: float) -> np.ndarray:
    """Trilinear, wrapping lookup of the tile at world points x (N, 3), one tile per `scale` m.

    Texel centres sit at (i + 0.5) / size, as in GL; kinds/noise.glsl does the same
    arithmetic with texelFetch.
    """
    n = tex.shape[0]
    p = np.asarray(x, dtype=np.float64) / scale * n - 0.5
    i0 = np.floor(p)
    f = p - i0
    i0 = i0.astype(np.int64)
    out = np.zeros(len(p))
    for dx in (0, 1):
        for dy in (0, 1):
            for dz in (0, 1):
                v = tex[(i0[:, 0] + dx) % n, (i0[:, 1] + dy) % n, (i0[:, 2] + dz) % n]
                wt = ((f[:, 0] if dx else 1 - f[:, 0]) * (f[:, 1] if dy else 1 - f[:, 1])
                      * (f[:, 2] if dz else 1 - f[:, 2]))
                out += wt * v
    return out


@lru_cache(maxsize=8)
def steps(size: int = 64, octaves: int = 4, blur: int = 2, seed: int = 7) -> tuple[float, float, float]:
    """The largest |difference| between neighbouring texels along x, y and z, wrapping.
    Each partial derivative of the trilinear interpolant is bounded by it (per texel)."""
    return texel_steps(bake(size, octaves, blur, seed))


def texel_steps(tex: np.ndarray) -> tuple[float, float, float]:
    """steps() of a given tile."""
    tex = tex.astype(np.float64)
    return tuple(float(np.abs(np.roll(tex, -1, axis=a) - tex).max()) for a in range(3))
