"""Sphere fog (Quilez): rho max(0, 1 - |x - s|^2 / R^2), integrated in the unit sphere."""

from __future__ import annotations

import numpy as np

from ._ray import slide


def density(layer, x, t, wind):
    r = slide(layer, x, t, wind) - np.asarray(layer.center)
    return layer.density * np.maximum(0.0, 1.0 - np.einsum("ij,ij->i", r, r) / layer.radius**2)


def optical_depth(layer, O, omega, d, t, wind):
    R = layer.radius
    rc = (slide(layer, O, t, wind) - np.asarray(layer.center)) / R
    b = np.einsum("ij,ij->i", omega, rc)
    c = np.einsum("ij,ij->i", rc, rc) - 1.0
    h = b * b - c
    hs = np.sqrt(np.maximum(h, 0.0))
    t1 = np.maximum(-b - hs, 0.0)
    t2 = np.minimum(-b + hs, d / R)
    hit = (h > 0) & (t2 > t1)

    def prim(x):  # antiderivative of 1 - |rc + x rd|^2 = -(c + 2 b x + x^2)
        return -(c * x + b * x * x + x**3 / 3.0)

    return np.where(hit, layer.density * R * (prim(t2) - prim(t1)), 0.0)
