"""Tiled polynomial fog (Biri 3.2.2): rho P(u), u = a . x + b on [-C, C]."""

from __future__ import annotations

import numpy as np
from numpy.polynomial import polynomial as npoly

from fogbank.kinds.rays import slide


def _tiled(layer, u):
    """Map u into the reference interval [-C, C) (repeat), or flag it outside (zero)."""
    C = layer.half_width
    if layer.mode == "repeat":
        n = np.floor((u + C) / (2 * C))
        return u - 2 * C * n, n, np.ones_like(u, dtype=bool)
    inside = (u >= -C) & (u <= C)
    return u, np.zeros_like(u), inside


def density(layer, x, t, wind):
    u = slide(layer, x, t, wind) @ np.asarray(layer.axis) + layer.offset
    r, _, inside = _tiled(layer, u)
    return layer.density * np.where(inside, npoly.polyval(r, layer.coeffs), 0.0)


def mean(layer, u0, u1):
    """The mean of P over [u0, u1] (P(u0) where they meet): sum c_i/(i+1) D_i with
    D_i = (u1^(i+1) - u0^(i+1)) / (u1 - u0) = sum_j u0^j u1^(i-j), built as
    D_i = u1 D_(i-1) + u0^i: products and sums, no difference of antiderivatives."""
    D = np.ones_like(u0)
    p = np.ones_like(u0)
    acc = np.full_like(u0, layer.coeffs[0])
    for i, c in enumerate(layer.coeffs[1:], start=1):
        p = p * u0
        D = u1 * D + p
        acc = acc + c / (i + 1) * D
    return acc


def optical_depth(layer, O, omega, d, t, wind):
    # as kinds/polynomial.glsl: the ray's u-interval [lo, hi] integrated tile by
    # tile (the partial tile at each end, whole tiles between), each piece its length
    # times P's mean over it; tau = density d * integral / (hi - lo), or d P(u) if flat.
    from fogbank.kinds.packing import coordinate_at
    a = np.asarray(layer.axis, dtype=np.float64)
    C = layer.half_width
    repeat = layer.mode == "repeat"
    w = np.asarray(wind, dtype=np.float64) if layer.wind else np.zeros(3)
    from fogbank.kinds.packing import EXACT_ABOVE
    x = (O - w[None, :] * t[:, None]) @ a + layer.offset
    big = (np.abs(O) + np.abs(w)[None, :] * t[:, None]) @ np.abs(a) + abs(layer.offset)
    u0 = x - 2 * C * np.floor((x + C) / (2 * C)) if repeat else x
    for i in np.nonzero(big >= EXACT_ABOVE)[0]:   # exactly, where float64 would lose digits
        u0[i] = coordinate_at(a, O[i], w, float(t[i]), layer.offset, 2 * C if repeat else None, C)
    u1 = u0 + (omega @ a) * d
    lo, hi = np.minimum(u0, u1), np.maximum(u0, u1)
    span = hi - lo
    flat = span == 0
    safe = np.where(flat, 1.0, span)
    if not repeat:
        left, right = np.maximum(lo, -C), np.minimum(hi, C)
        inside = right >= left
        frac = np.where(flat, 1.0, np.clip(right - left, 0.0, None) / safe)
        m = mean(layer, np.where(inside, left, 0.0), np.where(inside, right, 0.0))
        return layer.density * d * np.where(inside, frac * m, 0.0)
    n0, n1 = np.floor((lo + C) / (2 * C)), np.floor((hi + C) / (2 * C))
    r0 = np.clip(lo - 2 * C * n0, -C, C)
    r1 = np.clip(hi - 2 * C * n1, -C, C)
    Q = npoly.polyint(layer.coeffs)
    period = npoly.polyval(C, Q) - npoly.polyval(-C, Q)
    one = mean(layer, r0, r1)
    whole = ((C - r0) * mean(layer, r0, np.full_like(r0, C)) + (n1 - n0 - 1) * period
             + (r1 + C) * mean(layer, np.full_like(r1, -C), r1)) / safe
    return layer.density * d * np.where(n0 == n1, one, whole)
