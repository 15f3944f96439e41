"""The baked Perlin tile: range, seamless tiling, binomial blur, caching, lookup."""

from __future__ import annotations

import numpy as np

import pytest

from fogbank.kinds.noise_bake import BASE_CELLS, _perlin_octave, bake, binomial_blur, sample


def test_range_and_cache():
    a = bake(32, 3, 2, 1)
    assert a.dtype == np.float32 and a.shape == (32, 32, 32)
    assert a.min() == 0.0 and a.max() == 1.0
    assert bake(32, 3, 2, 1) is a
    assert not np.array_equal(a, bake(32, 3, 2, 2))


def test_tiles_without_seams():
    a = bake(32, 4, 2, 3).astype(np.float64)
    # the jump across the wrap is like any other neighbour step
    inner = np.abs(np.diff(a, axis=0)).mean()
    seam = np.abs(a[0] - a[-1]).mean()
    assert seam < 1.5 * inner
    x = np.random.default_rng(0).uniform(-100, 100, (500, 3))
    assert np.allclose(sample(a, x, 20.0), sample(a, x + [20.0, -40.0, 60.0], 20.0))


def test_binomial_blur_weights_and_wrap():
    a = np.zeros((8, 8, 8))
    a[0, 0, 0] = 1.0
    b = binomial_blur(a, 2)   # Pascal row (1, 2, 1) / 4 on each axis, wrapping
    assert np.isclose(b.sum(), 1.0)
    assert np.isclose(b[0, 0, 0], (2 / 4) ** 3)
    assert np.isclose(b[7, 0, 0], (1 / 4) * (2 / 4) ** 2)   # wrapped to the far side


def test_trilinear_hits_texel_centres():
    a = bake(16, 2, 1, 4)
    i = np.array([[3, 5, 7]])
    x = (i + 0.5) / 16 * 10.0
    assert np.isclose(sample(a, x, 10.0)[0], a[3, 5, 7])


@pytest.mark.parametrize("size,cells", [(8, 4), (33, 8), (40, 16), (99, 32), (64, 64), (40, 40)])
def test_an_octave_is_perlins_gradient_noise_at_every_texel_centre(size, cells):
    """Against Perlin's sum written out per texel (float64): the 8 lattice corners around
    the texel centre, each gradient dotted with the offset and weighted by the quintic
    fade; the gradients are the octave's first draws from its generator, unit length.
    Sizes that are and are not multiples of the lattice, and a lattice as fine as the tile."""
    got = _perlin_octave(size, cells, np.random.default_rng(11))
    g = np.random.default_rng(11).normal(size=(cells, cells, cells, 3))
    g /= np.linalg.norm(g, axis=-1, keepdims=True)
    texels = np.random.default_rng(size).integers(0, size, (150, 3))
    for t in [*texels, (0, 0, 0), (size - 1, size - 1, size - 1)]:
        p = (np.asarray(t) + 0.5) * cells / size
        i0 = np.floor(p).astype(int)
        f = p - i0
        want = 0.0
        fade = f * f * f * (f * (f * 6 - 15) + 10)   # Perlin 2002's quintic, per axis
        for d in np.ndindex(2, 2, 2):
            w = np.prod([fade[a] if d[a] else 1 - fade[a] for a in range(3)])
            want += w * float(np.dot(g[tuple((i0 + d) % cells)], f - np.asarray(d)))
        assert abs(got[tuple(t)] - want) < 1e-12


def _reference_tile(size, octaves, blur, seed):
    """The whole tile written out another way: each octave's 8 corner gradients gathered
    for every texel (the bake before 4999a68), the octaves drawn in turn from one
    generator, the binomial blur as an explicit wrapped convolution along each axis, then
    scaled to [0, 1]. A shared link's noise must not change with the bake's arithmetic."""
    from math import comb
    rng = np.random.default_rng(seed)
    total = np.zeros((size, size, size))
    for o in range(octaves):
        cells = min(BASE_CELLS * 2**o, size)
        g = rng.normal(size=(cells, cells, cells, 3))
        g /= np.linalg.norm(g, axis=-1, keepdims=True)
        p = (np.arange(size) + 0.5) * cells / size
        i0 = np.floor(p).astype(int)
        f = p - i0
        X, Y, Z = np.meshgrid(i0, i0, i0, indexing="ij")
        FX, FY, FZ = np.meshgrid(f, f, f, indexing="ij")
        fade = lambda t: t * t * t * (t * (t * 6 - 15) + 10)  # noqa: E731
        out = np.zeros((size, size, size))
        for dx, dy, dz in np.ndindex(2, 2, 2):
            gg = g[(X + dx) % cells, (Y + dy) % cells, (Z + dz) % cells]
            dot = gg[..., 0] * (FX - dx) + gg[..., 1] * (FY - dy) + gg[..., 2] * (FZ - dz)
            out += ((fade(FX) if dx else 1 - fade(FX)) * (fade(FY) if dy else 1 - fade(FY))
                    * (fade(FZ) if dz else 1 - fade(FZ)) * dot)
        total += 0.5**o * out
    if blur:
        w = [comb(blur, i) / 2.0**blur for i in range(blur + 1)]
        for axis in range(3):
            acc = np.zeros_like(total)
            for i, wi in enumerate(w):   # out[j] = sum_i w_i in[j - i + blur // 2], wrapping
                idx = (np.arange(size) - i + blur // 2) % size
                acc += wi * np.take(total, idx, axis=axis)
            total = acc
    return (total - total.min()) / (total.max() - total.min())


@pytest.mark.parametrize("args", [(16, 3, 2, 5), (33, 6, 1, 9), (40, 4, 3, 123), (64, 4, 2, 7)])
def test_the_tile_is_the_same_noise_for_the_same_parameters(args):
    bake.cache_clear()
    assert np.abs(bake(*args).astype(np.float64) - _reference_tile(*args)).max() < 1e-6
