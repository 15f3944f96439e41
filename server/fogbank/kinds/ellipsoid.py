"""Ellipsoid fog: the sphere's profile rho (1 - r^2) in the ellipsoid's metric, its edge
made harder by edge_fade, or a carving body.

With the body's frame R (rotation) and radii a = (a_x, a_y, a_z), r^2 = |diag(1/a) R
(x - c)|^2, and the density is rho min(1, max(0, 1 - r^2) / f), f = edge_fade: f = 1 is
Quilez's sphere profile, densest at the centre; a smaller f makes it constant inside the
radius sqrt(1 - f) and fade only across the edge (f -> 0: a hard ellipsoid). In that metric
the ellipsoid is the unit sphere and the ray O + w s is O' + w' s with |w'| = m: the
optical depth is (1/m) times the unit sphere's along the unit direction w'/m over the
length m d, exactly: (1/f) times the profile 1 - r^2 over the chord, less the same over the
inner sphere's chord (radius sqrt(1 - f)), plus that inner chord's length (kinds/sphere.py).

A carving body (carve > 0) adds no fog: inside itself it removes the share carve of every
other layer's fog (kinds/carving.py), in CARVE_SHELLS nested ellipsoids across its edge
fade f (at r^2 = 1 - f (k + 1/2) / K).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import ConfigDict, Field

from fogbank.kinds import sphere
from fogbank.kinds.box import CARVE_SHELLS, Extent, Oriented, carving_variant, pack_oriented, sample_oriented
from fogbank.kinds.kind import Env, Kind, Layout, exponential
from fogbank.kinds.rays import slide
from fogbank.model.fields import num


class Ellipsoid(Oriented):
    """The sphere's rho (1 - r^2) profile, r measured in the ellipsoid's radii, its edge
    harder below edge_fade 1."""
    model_config = ConfigDict(title="Fog ellipsoid")
    kind: Literal["ellipsoid"] = "ellipsoid"
    source = "fogbank: Quilez's sphere profile in an ellipsoid's metric"
    summary = ("An ellipsoid of fog, densest at its centre or even inside with a soft edge; with carve it "
               "removes the other layers' fog inside itself: a clearing in the fog.")
    formula = (r"\rho(\mathbf{x}) = \rho \min\left(1, \frac{\max(0,\ 1 - |M(\mathbf{x} - \mathbf{c})|^2)}{f}"
               r"\right)")
    radii: tuple[Extent, Extent, Extent] = Field(
        (20.0, 6.0, 12.0), description="semi-axes along the body's x, y, z, m (each 0.01-10000)")
    edge_fade: float = num(1.0, 0.01, 1, 0.01, "", "the profile: 1 densest at the centre (Quilez's 1 - r^2), "
                           "less for an even density inside and a fade over the outer shell of this depth "
                           "(in r^2)")


def _metric(layer, O, omega, t, env):
    """The rays in the unit-sphere metric: origins relative to the centre, and directions."""
    M = layer.axes() / np.asarray(layer.radii)[:, None]
    return (slide(layer, O, t, env.wind) - np.asarray(layer.center)) @ M.T, omega @ M.T


def density(layer, x, t, env):
    if layer.carving:
        return np.zeros(len(x))
    p, _ = _metric(layer, x, x, t, env)
    return layer.density * np.minimum(1.0, np.maximum(0.0, 1.0 - np.einsum("ij,ij->i", p, p)) / layer.edge_fade)


class _Unit:
    """A sphere at the origin of radius R in the metric, as sphere.optical_depth reads a layer."""
    center, wind = (0.0, 0.0, 0.0), False

    def __init__(self, density, radius=1.0):
        self.density, self.radius = density, radius


def unit_chords(o, v, d, r2: float):
    """The chords [s0, s1] of the rays o + v s (unit direction v, s in [0, d], the metric's
    units) inside the sphere r^2 <= r2, about each ray's closest approach."""
    b = -np.einsum("ij,ij->i", o, v)
    x = np.cross(o, v)
    a2 = r2 - np.einsum("ij,ij->i", x, x)
    a = np.sqrt(np.maximum(a2, 0.0))
    s0, s1 = np.maximum(b - a, 0.0), np.minimum(b + a, d)
    return np.where(a2 > 0, s0, 1.0), np.where(a2 > 0, s1, 0.0)


def optical_depth(layer, O, omega, d, t, env):
    if layer.carving:
        return np.zeros(len(d))
    o, v = _metric(layer, O, omega, t, env)
    m = np.linalg.norm(v, axis=1)
    u, dm = v / m[:, None], m * d
    flat = Env(wind=np.zeros(3), weight=env.weight)
    f = layer.edge_fade
    tau = sphere.optical_depth(_Unit(layer.density), o, u, dm, t, flat)   # the profile 1 - r^2 over the chord
    if f < 1.0:   # inside r^2 <= 1 - f the density is constant: take that shell's profile out, its length in
        R = np.sqrt(1.0 - f)
        inner = sphere.optical_depth(_Unit(layer.density, R), o, u, dm, t, flat)   # rho (1 - r^2/R^2) there
        s0, s1 = unit_chords(o, u, dm, 1.0 - f)
        length = np.maximum(s1 - s0, 0.0)
        # over the inner chord, (1 - r^2) = f + (1 - f)(1 - r^2 / R^2): its integral is
        # f length + (1 - f) inner / rho
        tau = (tau - (f * length * env.weight * layer.density + (1.0 - f) * inner)) / f + \
            env.weight * layer.density * length
    return tau / m


def shell_chords(layer, O, omega, d, t, env):
    """A carving ellipsoid's nested ellipsoids' chords along the rays (world units):
    [(share, s0, s1)], the k-th at r^2 = 1 - f (k + 1/2) / K (K = CARVE_SHELLS)."""
    o, v = _metric(layer, O, omega, t, env)
    m = np.linalg.norm(v, axis=1)
    u = v / m[:, None]
    f = layer.edge_fade
    out = []
    for k in range(CARVE_SHELLS):
        r2 = 1.0 - f * (k + 0.5) / CARVE_SHELLS
        s0, s1 = unit_chords(o, u, m * d, r2)
        out.append((1.0 / CARVE_SHELLS, s0 / m, s1 / m))
    return out


KIND = Kind(
    model=Ellipsoid,
    layout=Layout("ellipsoid", ("center", 3), ("density", 1), ("axis_x", 3), ("axis_y", 3),
                  ("axis_z", 3), ("inv_radii", 3), ("fade", 1)),
    pack=lambda layer, p: {**pack_oriented(layer, p), "inv_radii": 1.0 / np.asarray(layer.radii),
                           "fade": layer.edge_fade},
    code=exponential("ellipsoidOpticalDepth(Os, w, ds, {center}, {axis_x}, {axis_y}, {axis_z}, "
                     "{inv_radii}, {fade}, {density})"),
    carve_code=lambda r, v: (r.format("ellipsoidShellChord(Os, w, ds, {center}, {axis_x}, {axis_y}, {axis_z}, "
                                      "{inv_radii}, {fade}, k, shells)"), "CARVE_SHELLS", r.density),
    density_code=lambda r, v: r.format(
        "rho *= 1.0 - {density} * ellipsoidCarveShare(x, {center}, {axis_x}, {axis_y}, {axis_z}, {inv_radii}, {fade});"
        if v else "rho += ellipsoidDensity(x, {center}, {axis_x}, {axis_y}, {axis_z}, {inv_radii}, {fade}, {density});"),
    variant=carving_variant,
    sample=lambda rng: Ellipsoid(**sample_oriented(rng), radii=tuple(rng.uniform(1, 20, 3)),
                                 edge_fade=float(rng.choice([1.0, rng.uniform(0.05, 1)]))),
    optical_depth=optical_depth, density=density, shell_chords=shell_chords,
)
