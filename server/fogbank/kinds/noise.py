"""Noise fog (Perlin fog write-up): surface T = exp(-rho d n), or n integrated (volume)."""

from __future__ import annotations

import numpy as np

from fogbank.kinds import noise_bake as bake
from fogbank.kinds.rays import slide


def density(layer, tex, x, t, wind):
    return layer.density * bake.sample(tex, slide(layer, x, t, wind), layer.scale)


NOISE_TOL = 1e-3   # kinds/noise.glsl: the volume mode's target error in optical depth


def slope_bound(tex, omega, scale):
    """L: a bound on |dn/ds| along each ray (1/m). Each partial derivative of trilinear
    noise is at most the largest neighbouring-texel step along its axis (bake.steps)."""
    return tex.shape[0] / scale * (np.abs(omega) @ np.asarray(bake.texel_steps(tex)))


def volume_samples(layer, tex, omega, d, weight=1.0):
    """Samples per ray: the bound under NOISE_TOL, within [1, layer.samples]. The shader
    counts the optical depth with the global density (`weight`) inside, and so does this."""
    rho = weight * layer.density
    need = np.ceil(rho * slope_bound(tex, omega, layer.scale) * d * d / (4.0 * NOISE_TOL))
    return np.clip(need, 1, layer.samples)


def optical_depth(layer, tex, O, omega, d, t, wind, weight=1.0):
    if layer.mode == "volume":
        # the midpoint rule with the sample count the shader picks for each ray
        n = volume_samples(layer, tex, omega, d, weight)
        tau = np.zeros(len(d))
        for i in range(int(n.max(initial=1))):
            x = O + omega * (d * (i + 0.5) / n)[:, None]
            tau += np.where(i < n, density(layer, tex, x, t, wind), 0.0)
        return tau * d / n
    P = O + omega * d[:, None]
    n = bake.sample(tex, slide(layer, P, t, wind), layer.scale)
    if layer.height_falloff:
        dy = (O[:, 1] - P[:, 1]) / layer.falloff_scale
        n = n * dy * dy / 2.0 + 0.001  # write-up: n = n dY^2 / 2 + 0.001
    return layer.density * d * n
