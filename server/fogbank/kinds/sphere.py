"""Sphere fog (Quilez): rho max(0, 1 - |x - s|^2 / R^2), integrated in the unit sphere."""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import ConfigDict, Field

from fogbank.kinds.kind import Kind, Layout, exponential
from fogbank.kinds.rays import slide
from fogbank.model.fields import LayerBase, Position, num


class Sphere(LayerBase):
    """Quilez: density * max(0, 1 - |x - center|^2 / radius^2)."""
    model_config = ConfigDict(title="Fog sphere")
    kind: Literal["sphere"] = "sphere"
    source = "Quilez, analytically integrated volumetric media"
    summary = "A ball of fog, densest at its centre and gone at its edge, integrated in closed form."
    formula = r"\rho(\mathbf{x}) = \rho \max\left(0,\ 1 - \frac{|\mathbf{x} - \mathbf{s}|^2}{R^2}\right)"
    center: Position = Field((0.0, 8.0, 0.0), description="m")
    radius: float = num(15.0, 0.01, 1000, 0.1, "m", "the sphere's radius", gt=True, title="radius R")
    density: float = num(0.1, 0, 10, 0.001, "1/m", "density at the centre", title="density ρ")


def density(layer, x, t, env):
    r = slide(layer, x, t, env.wind) - np.asarray(layer.center)
    return layer.density * np.maximum(0.0, 1.0 - np.einsum("ij,ij->i", r, r) / layer.radius**2)


def optical_depth(layer, O, omega, d, t, env):
    # about the closest approach (as kinds/sphere.glsl): q = c - O, b = q . w,
    # h^2 = |q x w|^2, a2 = 1 - h^2 / R^2; over t in [t0, t1] (segment and chord),
    # rho (t1 - t0) (a2 - (t0^2 + t0 t1 + t1^2) / (3 R^2))
    R = layer.radius
    q = np.asarray(layer.center) - slide(layer, O, t, env.wind)
    b = np.einsum("ij,ij->i", q, omega)
    x = np.cross(q, omega)
    a2 = 1.0 - np.einsum("ij,ij->i", x, x) / R**2
    a = R * np.sqrt(np.maximum(a2, 0.0))
    s0 = np.maximum(b - a, 0.0)      # the chord clipped to the segment, along the ray
    s1 = np.minimum(b + a, d)
    t0, t1 = s0 - b, s1 - b
    hit = (a2 > 0) & (s1 > s0)
    mean = np.maximum(a2 - (t0 * t0 + t0 * t1 + t1 * t1) / (3.0 * R**2), 0.0)
    return np.where(hit, env.weight * layer.density * (s1 - s0) * mean, 0.0)


def sample(rng):
    return Sphere(center=tuple(rng.normal(size=3) * 8), radius=rng.uniform(1, 20),
                  density=rng.uniform(0, 0.3), wind=bool(rng.random() < 0.5))


KIND = Kind(
    model=Sphere,
    layout=Layout("sphere", ("center", 3), ("radius", 1), ("density", 1)),
    pack=lambda layer, p: {"center": np.asarray(layer.center) - p.slid(layer),
                           "radius": layer.radius, "density": p.density * layer.density},
    code=exponential("sphereOpticalDepth(Os, w, ds, {center}, {radius}, {density})"),
    density_code=lambda r, v: r.format("rho += sphereDensity(x, {center}, {radius}, {density});"),
    sample=sample, optical_depth=optical_depth, density=density,
    loop=False,   # tiny code: inlined (kinds/kind.py Kind.loop)
)
