"""Point and line potentials (Biri 3.2.3, eq. 9): a / (c + e r^2)."""

from __future__ import annotations

import numpy as np

from ._ray import slide


def _axis(layer):
    if layer.shape == "point":
        return np.zeros(3)
    v = np.asarray(layer.direction, dtype=np.float64)
    return v / np.linalg.norm(v)


def _perp(v, u):
    """Component of v perpendicular to the unit axis u (u = 0 for a point)."""
    return v - np.outer(v @ u, u)


def density(layer, x, t, wind):
    q = _perp(slide(layer, x, t, wind) - np.asarray(layer.center), _axis(layer))
    r2 = np.einsum("ij,ij->i", q, q)
    return layer.strength / (layer.c + layer.e * r2)


def optical_depth(layer, O, omega, d, t, wind):
    # r^2(s) = |q + s w_perp|^2 = (m s + b)^2 + h^2 with m = |w_perp|, b = q . w_perp / m;
    # integral a / (K + e z^2) dz / m, K = c + e h^2, gives an arctangent difference,
    # written as atan2(y, 1 + x0 x1) / y so that m -> 0 (ray along the line) stays exact.
    u = _axis(layer)
    q = _perp(slide(layer, O, t, wind) - np.asarray(layer.center), u)
    wp = _perp(omega, u)
    m = np.linalg.norm(wp, axis=1)
    wn = wp / np.where(m > 0, m, 1.0)[:, None]
    b = np.einsum("ij,ij->i", q, wn)
    h2 = np.maximum(np.einsum("ij,ij->i", q, q) - b * b, 0.0)
    K = layer.c + layer.e * h2
    s = np.sqrt(layer.e / K)
    x0 = s * b
    x1 = s * (b + m * d)
    y = s * m * d
    x = 1.0 + x0 * x1
    ysafe = np.where(y > 0, y, 1.0)
    ratio = np.where(y > 1e-8, np.arctan2(y, x) / ysafe, 1.0 / x)
    return layer.strength * d / K * ratio
