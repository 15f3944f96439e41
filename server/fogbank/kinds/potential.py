"""Point and line potentials (Biri 3.2.3, eq. 9): a / (c + e r^2)."""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import ConfigDict, Field, model_validator

from fogbank.kinds.kind import Kind, Layout, exponential
from fogbank.kinds.rays import slide
from fogbank.model.fields import Direction, LayerBase, Position, num


class Potential(LayerBase):
    """Biri 3.2.3, eq. 9: strength / (c + e r^2), r the distance to a point or a line."""
    model_config = ConfigDict(title="Potential blob")
    kind: Literal["potential"] = "potential"
    source = "Biri, Michelin & Arquès 2002, section 3.2.3, eq. 9"
    summary = "A soft blob of fog round a point, or a long one along a line, thickest at its centre."
    formula = r"\rho(\mathbf{x}) = \frac{a}{c + e\, r(\mathbf{x})^2}"
    shape: Literal["point", "line"] = "point"
    center: Position = Field((0.0, 5.0, 0.0), description="the point, or a point on the line, m")
    direction: Direction = Field((0.0, 1.0, 0.0), description="the line's direction (unused for a point)")
    strength: float = num(1.0, 0, 1000, 0.01, "1/m", "numerator a", title="strength a")
    c: float = num(20.0, 1e-3, 1e6, 0.1, "", "constant term c > 0: the peak density is a / c", gt=True, title="constant c")
    e: float = num(1.0, 1e-6, 1e3, 0.01, "1/m^2", "r^2 weight e > 0: larger is a tighter blob", gt=True, title="falloff e")

    @model_validator(mode="after")
    def _line_direction(self) -> "Potential":
        if self.shape == "line" and math.hypot(*self.direction) < 1e-6:
            raise ValueError("a line potential needs a non-zero direction")
        return self


def _axis(layer):
    if layer.shape == "point":
        return np.zeros(3)
    v = np.asarray(layer.direction, dtype=np.float64)
    return v / np.linalg.norm(v)


def _perp(v, u):
    """Component of v perpendicular to the unit axis u (u = 0 for a point)."""
    return v - np.outer(v @ u, u)


def density(layer, x, t, env):
    q = _perp(slide(layer, x, t, env.wind) - np.asarray(layer.center), _axis(layer))
    r2 = np.einsum("ij,ij->i", q, q)
    return layer.strength / (layer.c + layer.e * r2)


def optical_depth(layer, O, omega, d, t, env):
    # in the plane across the axis, q = center - O, wn = w_perp / m: r^2(s) = (m s - b)^2 + h^2
    # with b = q . wn and h = |q x wn| (a cross product: |q|^2 - b^2 cancels for far centres);
    # integral a / (K + e z^2) dz / m, K = c + e h^2, gives an arctangent difference,
    # written as atan2(y, 1 + x0 x1) / y so that m -> 0 (ray along the line) stays exact.
    u = _axis(layer)
    q = _perp(np.asarray(layer.center) - slide(layer, O, t, env.wind), u)
    wp = _perp(omega, u)
    m = np.linalg.norm(wp, axis=1)
    along = m > 0
    wn = wp / np.where(along, m, 1.0)[:, None]
    b = np.where(along, np.einsum("ij,ij->i", q, wn), 0.0)
    x = np.cross(q, wn)
    h2 = np.where(along, np.einsum("ij,ij->i", x, x), np.einsum("ij,ij->i", q, q))
    K = layer.c + layer.e * h2
    s = np.sqrt(layer.e / K)
    x0 = -s * b
    x1 = s * (m * d - b)
    y = s * m * d
    xx = 1.0 + x0 * x1
    ysafe = np.where(y > 0, y, 1.0)
    ratio = np.where(y > 1e-8, np.arctan2(y, xx) / ysafe, 1.0 / xx)
    return env.weight * layer.strength * d / K * ratio


def pack(layer, p):
    axis = np.zeros(3)
    if layer.shape == "line":
        axis = np.asarray(layer.direction, dtype=np.float64)
        axis /= np.linalg.norm(axis)
    q = np.asarray(layer.center) - p.slid(layer)
    q = q - np.dot(q, axis) * axis   # across the line, here in float64: a centre given far
    return {"center": q, "strength": p.density * layer.strength,   # along the line costs no digits
            "axis": axis, "c": layer.c, "e": layer.e}


def sample(rng):
    return Potential(shape=str(rng.choice(["point", "line"])), center=tuple(rng.normal(size=3) * 10),
                     direction=tuple(rng.normal(size=3)), strength=rng.uniform(0, 2),
                     c=rng.uniform(0.5, 30), e=rng.uniform(0.01, 2), wind=bool(rng.random() < 0.5))


KIND = Kind(
    model=Potential,
    layout=Layout("potential", ("center", 3), ("strength", 1), ("axis", 3), ("c", 1), ("e", 1)),
    pack=pack,
    code=exponential("potentialOpticalDepth(Os, w, ds, {center}, {axis}, {strength}, {c}, {e})"),
    density_code=lambda r, v: r.format("rho += potentialDensity(x, {center}, {axis}, {strength}, {c}, {e});"),
    sample=sample, optical_depth=optical_depth, density=density,
)
