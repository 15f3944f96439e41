"""Box fog: constant density inside an axis-aligned or rotated box.

tau = rho * (the length of the ray inside the box), the chord found by the slab method
(Kay and Kajiya 1986): the ray's parameter interval inside each pair of parallel faces,
intersected. A negative density carves fog out of the other layers (Biri 2002, 3.2:
objects may be subtracted; Godot's FogVolume allows a negative density); the shader keeps
the total optical depth at 0 or more.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

import numpy as np
from pydantic import ConfigDict, Field

from fogbank.kinds.kind import Kind, Layout, exponential
from fogbank.kinds.rays import slide
from fogbank.model.fields import LayerBase, Position, num

# a half extent or a radius, m
Extent = Annotated[float, Field(strict=True, ge=0.01, le=10000)]


class Oriented(LayerBase):
    """A body placed in the scene: centre and orientation (yaw about +y, then pitch about
    the body's x, then roll about its z), shared by the box and the ellipsoid."""
    center: Position = Field((0.0, 6.0, 0.0), description="m")
    yaw: float = num(0.0, -360, 360, 1, "deg", "turn about the vertical; positive turns +z toward +x")
    pitch: float = num(0.0, -180, 180, 1, "deg", "tilt about the body's x axis; positive tips its +y toward +z")
    roll: float = num(0.0, -180, 180, 1, "deg", "turn about the body's z axis")
    density: float = num(0.1, -10, 10, 0.001, "1/m",
                         "density inside; negative carves fog out (the total optical depth stays >= 0)")

    def axes(self) -> np.ndarray:
        """The body's unit axes as the rows of a 3x3 matrix (world -> body: R @ x)."""
        y, p, r = (math.radians(a) for a in (self.yaw, self.pitch, self.roll))
        Ry = np.array([[math.cos(y), 0, math.sin(y)], [0, 1, 0], [-math.sin(y), 0, math.cos(y)]])
        Rx = np.array([[1, 0, 0], [0, math.cos(p), -math.sin(p)], [0, math.sin(p), math.cos(p)]])
        Rz = np.array([[math.cos(r), -math.sin(r), 0], [math.sin(r), math.cos(r), 0], [0, 0, 1]])
        return (Ry @ Rx @ Rz).T   # columns of Ry Rx Rz are the body's axes in the world


class Box(Oriented):
    """A box of constant density: tau = density * chord length (slab method)."""
    model_config = ConfigDict(title="Fog box")
    kind: Literal["box"] = "box"
    source = "fogbank: a box's chord by the slab method"
    summary = "A box of constant fog, turned any way: fog lying along a river, a bank of cloud. A negative density carves fog out."
    formula = r"\tau = \rho\, \ell_{\mathrm{box}}, \quad T = e^{-\tau}"
    half_size: tuple[Extent, Extent, Extent] = Field(
        (10.0, 4.0, 10.0), description="half extents along the box's x, y, z, m (each 0.01-10000)")


def _local(layer, O, omega, t, env):
    """The rays in the body's frame: origins relative to the centre, and directions."""
    R = layer.axes()
    return (slide(layer, O, t, env.wind) - np.asarray(layer.center)) @ R.T, omega @ R.T


def density(layer, x, t, env):
    p, _ = _local(layer, x, x, t, env)
    inside = np.all(np.abs(p) <= np.asarray(layer.half_size), axis=1)
    return np.where(inside, layer.density, 0.0)


def optical_depth(layer, O, omega, d, t, env):
    o, v = _local(layer, O, omega, t, env)
    h = np.asarray(layer.half_size)
    s0, s1 = np.zeros(len(d)), d.astype(np.float64).copy()
    for i in range(3):
        par = v[:, i] == 0
        with np.errstate(divide="ignore", invalid="ignore"):
            ta = (-h[i] - o[:, i]) / v[:, i]
            tb = (h[i] - o[:, i]) / v[:, i]
        lo = np.where(par, np.where(np.abs(o[:, i]) <= h[i], -np.inf, np.inf), np.minimum(ta, tb))
        hi = np.where(par, np.where(np.abs(o[:, i]) <= h[i], np.inf, -np.inf), np.maximum(ta, tb))
        s0, s1 = np.maximum(s0, lo), np.minimum(s1, hi)
    return env.weight * layer.density * np.maximum(s1 - s0, 0.0)


def pack_oriented(layer, p) -> dict:
    R = layer.axes()
    return {"center": np.asarray(layer.center) - p.slid(layer), "density": p.density * layer.density,
            "axis_x": R[0], "axis_y": R[1], "axis_z": R[2]}


def sample_oriented(rng) -> dict:
    return dict(center=tuple(rng.normal(size=3) * 8), yaw=rng.uniform(-180, 180),
                pitch=float(rng.choice([0.0, rng.uniform(-90, 90)])), roll=rng.uniform(-45, 45),
                density=float(rng.choice([rng.uniform(0, 0.3), rng.uniform(-0.3, 0)])),
                wind=bool(rng.random() < 0.5))


KIND = Kind(
    model=Box,
    layout=Layout("box", ("center", 3), ("density", 1), ("axis_x", 3), ("axis_y", 3), ("axis_z", 3),
                  ("half_size", 3)),
    pack=lambda layer, p: {**pack_oriented(layer, p), "half_size": layer.half_size},
    code=exponential("boxOpticalDepth(Os, w, ds, {center}, {axis_x}, {axis_y}, {axis_z}, "
                     "{half_size}, {density})"),
    density_code=lambda r, v: r.format("rho += boxDensity(x, {center}, {axis_x}, {axis_y}, {axis_z}, "
                                       "{half_size}, {density});"),
    sample=lambda rng: Box(**sample_oriented(rng), half_size=tuple(rng.uniform(0.5, 15, 3))),
    optical_depth=optical_depth, density=density,
)
