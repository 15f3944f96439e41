"""Tiled polynomial fog (Biri 3.2.2): rho P(u), u = a . x + b on [-C, C]."""

from __future__ import annotations

import numpy as np
from numpy.polynomial import polynomial as npoly

from ._ray import slide


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


def running_integral(layer, u):
    """G(u) = integral from 0 to u of the tiled (or zero-extended) P."""
    C = layer.half_width
    Q = npoly.polyint(layer.coeffs)  # Q(0) = 0
    if layer.mode == "repeat":
        r, n, _ = _tiled(layer, u)
        period = npoly.polyval(C, Q) - npoly.polyval(-C, Q)
        return n * period + npoly.polyval(r, Q)
    return npoly.polyval(np.clip(u, -C, C), Q)


def optical_depth(layer, O, omega, d, t, wind):
    # u moves at rate a . omega along the ray: tau = (G(u1) - G(u0)) / (a . omega).
    # Both ends are first shifted by the same whole number of periods (G is periodic up
    # to a constant) so the difference does not cancel against a large G(u0).
    a = np.asarray(layer.axis, dtype=np.float64)
    C = layer.half_width
    u0 = slide(layer, O, t, wind) @ a + layer.offset
    rate = omega @ a
    du = rate * d
    if layer.mode == "repeat":
        u0 = u0 - 2 * C * np.floor((u0 + C) / (2 * C))
    u1 = u0 + du
    # |du| below 1e-6 C: the midpoint rule, error (du)^2 P'' d / 24, beats the cancellation
    # of G(u1) - G(u0) (about 1e-16 / du relative)
    flat = np.abs(du) < 1e-6 * C
    safe = np.where(flat, 1.0, rate)
    tau = (running_integral(layer, u1) - running_integral(layer, u0)) / safe
    r, _, inside = _tiled(layer, u0 + du / 2)
    limit = d * np.where(inside, npoly.polyval(r, layer.coeffs), 0.0)
    return layer.density * np.where(flat, limit, tau)
