"""Point and line potentials (Biri 3.2.3, eq. 9): a / (c + e r^2)."""

from __future__ import annotations

import numpy as np

from fogbank.kinds.rays import slide


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
    # in the plane across the axis, q = center - O, wn = w_perp / m: r^2(s) = (m s - b)^2 + h^2
    # with b = q . wn and h = |q x wn| (a cross product: |q|^2 - b^2 cancels for far centres);
    # integral a / (K + e z^2) dz / m, K = c + e h^2, gives an arctangent difference,
    # written as atan2(y, 1 + x0 x1) / y so that m -> 0 (ray along the line) stays exact.
    u = _axis(layer)
    q = _perp(np.asarray(layer.center) - slide(layer, O, t, wind), u)
    wp = _perp(omega, u)
    m = np.linalg.norm(wp, axis=1)
    along = m > 0
    wn = wp / np.where(along, m, 1.0)[:, None]
    b = np.where(along, np.einsum("ij,ij->i", q, wn), 0.0)
    x = np.cross(q, wn)
    h2 = np.where(along, np.einsum("ij,ij->i", x, x), np.einsum("ij,ij->i", q, q))
    K = layer.c + layer.e * h2
    s = np.sqrt(layer.e / K)
    x0 = -s * b
    x1 = s * (m * d - b)
    y = s * m * d
    xx = 1.0 + x0 * x1
    ysafe = np.where(y > 0, y, 1.0)
    ratio = np.where(y > 1e-8, np.arctan2(y, xx) / ysafe, 1.0 / xx)
    return layer.strength * d / K * ratio
