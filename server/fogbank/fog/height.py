"""Height fog (Unreal/Filament): rho exp(-k (y - h0))."""

from __future__ import annotations

import numpy as np

from ._ray import slide


def density(layer, x, t, wind):
    x = slide(layer, x, t, wind)
    return layer.density * np.exp(-layer.falloff * (x[:, 1] - layer.base))


def exprel_neg(x):
    """(1 - exp(-x)) / x, with its limit 1 at x = 0 (series below |x| < 1e-5)."""
    x = np.asarray(x, dtype=np.float64)
    small = np.abs(x) < 1e-5
    safe = np.where(small, 1.0, x)
    return np.where(small, 1.0 - x / 2.0 + x * x / 6.0, -np.expm1(-safe) / safe)


def optical_depth(layer, O, omega, d, t, wind):
    # tau = rho d exp(-k (O_y - h0)) (1 - exp(-k d w_y)) / (k d w_y)
    O = slide(layer, O, t, wind)
    k = layer.falloff
    return layer.density * d * np.exp(-k * (O[:, 1] - layer.base)) * exprel_neg(k * d * omega[:, 1])
