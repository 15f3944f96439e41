"""The volume noise's quadrature (kinds/noise.py, mirrored by kinds/noise.glsl): with each
point at any share j of its interval (a frame's per-pixel jitter; 0.5 for rays), the
optical depth stays within its stated bound rho L d^2 (j^2 + (1 - j)^2) / (2 S) of the
exact line integral of the trilinear noise (tests/quadrature.py, Simpson on each lattice
cell, exact for the cubic pieces)."""

from __future__ import annotations

import numpy as np
import pytest

from fogbank.kinds import noise as noise_kind
from fogbank.kinds.kind import Env
from fogbank.kinds.noise import Noise
from fogbank.kinds.noise_bake import bake
from quadrature import noise_line_integral

TEX = bake(64, 4, 2, 7)


@pytest.mark.parametrize("j", [0.0, 0.2, 0.5, 0.93, 0.999])
def test_jittered_volume_quadrature_keeps_its_stated_bound(j):
    rng = np.random.default_rng(int(j * 1000) + 3)
    env = Env(wind=np.zeros(3), tex=TEX)
    tight = 0
    for i in range(40):
        layer = Noise(mode="volume", density=float(rng.uniform(0.001, 0.05)),
                      scale=float(rng.uniform(5, 80)), samples=int(rng.integers(1, 129)), wind=False)
        O = rng.uniform(-60, 60, (1, 3))
        w = rng.normal(size=(1, 3))
        w /= np.linalg.norm(w)
        d = np.array([float(rng.uniform(0.5, 120) if i % 2 else rng.uniform(0.1, 8))])
        got = float(noise_kind.optical_depth(layer, O, w, d, np.zeros(1), env, jitter=j)[0])
        exact = layer.density * noise_line_integral(TEX, O[0], w[0], d[0], layer.scale)
        S = float(noise_kind.volume_samples(layer, TEX, w, d, 1.0, j)[0])
        L = float(noise_kind.slope_bound(TEX, w, layer.scale)[0])
        bound = layer.density * L * d[0] ** 2 * (j * j + (1 - j) ** 2) / (2 * S)
        assert abs(got - exact) <= bound * (1 + 1e-9) + 1e-12
        if S < layer.samples:          # the count was free to meet the tolerance
            assert bound <= noise_kind.NOISE_TOL * (1 + 1e-9)
            tight += 1
    assert tight >= 5
