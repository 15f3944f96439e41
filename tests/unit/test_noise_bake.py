"""The baked Perlin tile: range, seamless tiling, binomial blur, caching, lookup."""

from __future__ import annotations

import numpy as np

import pytest

from fogbank.kinds.noise_bake import _fade, _perlin_octave, bake, binomial_blur, sample


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


@pytest.mark.parametrize("size,cells", [(8, 4), (33, 8), (40, 16), (99, 32), (64, 64)])
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
        for d in np.ndindex(2, 2, 2):
            w = np.prod([_fade(f[a]) if d[a] else 1 - _fade(f[a]) for a in range(3)])
            want += w * float(np.dot(g[tuple((i0 + d) % cells)], f - np.asarray(d)))
        assert abs(got[tuple(t)] - want) < 1e-12
