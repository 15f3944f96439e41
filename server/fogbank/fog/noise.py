"""Noise fog (Perlin fog write-up): surface T = exp(-rho d n), or n integrated (volume)."""

from __future__ import annotations

import numpy as np

from .. import noise as bake
from ._ray import slide


def density(layer, tex, x, t, wind):
    return layer.density * bake.sample(tex, slide(layer, x, t, wind), layer.scale)


def optical_depth(layer, tex, O, omega, d, t, wind):
    if layer.mode == "volume":
        # midpoint rule with `samples` points, the same points the shader takes
        n = layer.samples
        tau = np.zeros(len(d))
        for i in range(n):
            x = O + omega * (d * (i + 0.5) / n)[:, None]
            tau += density(layer, tex, x, t, wind)
        return tau * d / n
    P = O + omega * d[:, None]
    n = bake.sample(tex, slide(layer, P, t, wind), layer.scale)
    if layer.height_falloff:
        dy = (O[:, 1] - P[:, 1]) / layer.falloff_scale
        n = n * dy * dy / 2.0 + 0.001  # write-up: n = n dY^2 / 2 + 0.001
    return layer.density * d * n
