"""Helpers shared by the references: array shapes and the wind slide."""

from __future__ import annotations

import numpy as np


def as_rays(O, omega, d, t=0.0):
    O = np.atleast_2d(np.asarray(O, dtype=np.float64))
    omega = np.atleast_2d(np.asarray(omega, dtype=np.float64))
    n = max(len(O), len(omega))
    d = np.broadcast_to(np.asarray(d, dtype=np.float64), (n,)).copy()
    t = np.broadcast_to(np.asarray(t, dtype=np.float64), (n,)).copy()
    return np.broadcast_to(O, (n, 3)), np.broadcast_to(omega, (n, 3)), d, t


def velocity(layer, wind) -> np.ndarray:
    """The velocity a layer's density slides with: the wind for a wind-sensitive layer,
    plus the layer's own drift (the noise kinds)."""
    v = np.asarray(wind, dtype=np.float64) if layer.wind else np.zeros(3)
    return v + np.asarray(getattr(layer, "drift", (0.0, 0.0, 0.0)), dtype=np.float64)


def slide(layer, x, t, wind):
    """DESIGN: a density rho(x) moving at velocity v becomes rho(x - v t)."""
    v = velocity(layer, wind)
    if not v.any():
        return x
    return x - v[None, :] * np.asarray(t)[:, None]
