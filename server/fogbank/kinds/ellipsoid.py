"""Ellipsoid fog: the sphere's profile rho (1 - r^2) in the ellipsoid's metric.

With the body's frame R (rotation) and radii a = (a_x, a_y, a_z), r^2 = |diag(1/a) R
(x - c)|^2, so the density is rho max(0, 1 - r^2). In that metric the ellipsoid is the
unit sphere and the ray O + w s is O' + w' s with |w'| = m: the optical depth is
(1/m) times the unit sphere's closed form along the unit direction w'/m over the length
m d (kinds/sphere.py), exactly. A negative density carves fog out (the total optical
depth stays >= 0).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import ConfigDict, Field

from fogbank.kinds import sphere
from fogbank.kinds.box import Extent, Oriented, pack_oriented, sample_oriented
from fogbank.kinds.kind import Env, Kind, Layout, exponential
from fogbank.kinds.rays import slide


class Ellipsoid(Oriented):
    """The sphere's rho (1 - r^2) profile, r measured in the ellipsoid's radii."""
    model_config = ConfigDict(title="Fog ellipsoid")
    kind: Literal["ellipsoid"] = "ellipsoid"
    source = "fogbank: Quilez's sphere profile in an ellipsoid's metric"
    summary = "An ellipsoid of fog, densest at its centre; a negative density carves a clearing out of the fog around it."
    formula = r"\rho(\mathbf{x}) = \rho \max\left(0,\ 1 - |M(\mathbf{x} - \mathbf{c})|^2\right)"
    radii: tuple[Extent, Extent, Extent] = Field(
        (20.0, 6.0, 12.0), description="semi-axes along the body's x, y, z, m (each 0.01-10000)")


def _metric(layer, O, omega, t, env):
    """The rays in the unit-sphere metric: origins relative to the centre, and directions."""
    M = layer.axes() / np.asarray(layer.radii)[:, None]
    return (slide(layer, O, t, env.wind) - np.asarray(layer.center)) @ M.T, omega @ M.T


def density(layer, x, t, env):
    p, _ = _metric(layer, x, x, t, env)
    return layer.density * np.maximum(0.0, 1.0 - np.einsum("ij,ij->i", p, p))


class _Unit:
    """The unit sphere at the origin, as sphere.optical_depth reads a layer."""
    center, radius, wind = (0.0, 0.0, 0.0), 1.0, False

    def __init__(self, density):
        self.density = density


def optical_depth(layer, O, omega, d, t, env):
    o, v = _metric(layer, O, omega, t, env)
    m = np.linalg.norm(v, axis=1)
    tau = sphere.optical_depth(_Unit(layer.density), o, v / m[:, None], m * d, t,
                               Env(wind=np.zeros(3), weight=env.weight))
    return tau / m


KIND = Kind(
    model=Ellipsoid,
    layout=Layout("ellipsoid", ("center", 3), ("density", 1), ("axis_x", 3), ("axis_y", 3),
                  ("axis_z", 3), ("inv_radii", 3)),
    pack=lambda layer, p: {**pack_oriented(layer, p), "inv_radii": 1.0 / np.asarray(layer.radii)},
    code=exponential("ellipsoidOpticalDepth(Os, w, ds, {center}, {axis_x}, {axis_y}, {axis_z}, "
                     "{inv_radii}, {density})"),
    density_code=lambda r, v: r.format("rho += ellipsoidDensity(x, {center}, {axis_x}, {axis_y}, "
                                       "{axis_z}, {inv_radii}, {density});"),
    sample=lambda rng: Ellipsoid(**sample_oriented(rng), radii=tuple(rng.uniform(1, 20, 3))),
    optical_depth=optical_depth, density=density,
)
