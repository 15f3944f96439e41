"""Height fog (Unreal/Filament): rho exp(-k (y - h0))."""

from __future__ import annotations

import numpy as np

from fogbank.kinds.rays import slide


def density(layer, x, t, wind):
    x = slide(layer, x, t, wind)
    return layer.density * np.exp(-layer.falloff * (x[:, 1] - layer.base))


def exprel_neg(x):
    """(1 - exp(-x)) / x, with its limit 1 at x = 0 (series below |x| < 1e-5)."""
    x = np.asarray(x, dtype=np.float64)
    small = np.abs(x) < 1e-5
    safe = np.where(small, 1.0, x)
    return np.where(small, 1.0 - x / 2.0 + x * x / 6.0, -np.expm1(-safe) / safe)


def optical_depth(layer, O, omega, d, t, wind, weight=1.0):
    """weight (the global density) multiplies the result inside the logarithm, where a tiny
    weight over a huge depth (e^3000 under the base) stays representable."""
    # tau = d rho(y_lo) (1 - exp(-k d |w_y|)) / (k d |w_y|), y_lo the segment's lower end:
    # one exponential of the height difference, exprel in (0, 1], taken as
    # exp(log rho - k (y_lo - h0) + log d + log exprel) so that no factor overflows alone
    O = slide(layer, O, t, wind)
    k = layer.falloff
    if layer.density <= 0 or weight <= 0:
        return np.zeros(len(d))
    y_lo = O[:, 1] + np.minimum(d * omega[:, 1], 0.0)
    with np.errstate(divide="ignore"):
        e = (np.log(layer.density) + np.log(weight) - k * (y_lo - layer.base) + np.log(d)
             + np.log(exprel_neg(k * d * np.abs(omega[:, 1]))))
    return np.where(d > 0, np.exp(np.minimum(e, 700.0)), 0.0)
