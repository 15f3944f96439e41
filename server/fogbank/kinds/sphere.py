"""Sphere fog (Quilez): rho max(0, 1 - |x - s|^2 / R^2), integrated in the unit sphere."""

from __future__ import annotations

import numpy as np

from fogbank.kinds.rays import slide


def density(layer, x, t, wind):
    r = slide(layer, x, t, wind) - np.asarray(layer.center)
    return layer.density * np.maximum(0.0, 1.0 - np.einsum("ij,ij->i", r, r) / layer.radius**2)


def optical_depth(layer, O, omega, d, t, wind):
    # about the closest approach (as kinds/sphere.glsl): q = c - O, b = q . w,
    # h^2 = |q x w|^2, a2 = 1 - h^2 / R^2; over t in [t0, t1] (segment and chord),
    # rho (t1 - t0) (a2 - (t0^2 + t0 t1 + t1^2) / (3 R^2))
    R = layer.radius
    q = np.asarray(layer.center) - slide(layer, O, t, wind)
    b = np.einsum("ij,ij->i", q, omega)
    x = np.cross(q, omega)
    a2 = 1.0 - np.einsum("ij,ij->i", x, x) / R**2
    a = R * np.sqrt(np.maximum(a2, 0.0))
    s0 = np.maximum(b - a, 0.0)      # the chord clipped to the segment, along the ray
    s1 = np.minimum(b + a, d)
    t0, t1 = s0 - b, s1 - b
    hit = (a2 > 0) & (s1 > s0)
    mean = np.maximum(a2 - (t0 * t0 + t0 * t1 + t1 * t1) / (3.0 * R**2), 0.0)
    return np.where(hit, layer.density * (s1 - s0) * mean, 0.0)
