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


def slide(layer, x, t, wind):
    """DESIGN: a wind-sensitive density rho(x) becomes rho(x - w t)."""
    if not layer.wind:
        return x
    return x - np.asarray(wind, dtype=np.float64)[None, :] * np.asarray(t)[:, None]
