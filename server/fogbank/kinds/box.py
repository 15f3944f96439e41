"""Box fog: constant density inside an axis-aligned or rotated box, its faces softened by an
edge fade (Godot's FogVolume edge fade), or a carving body.

The density is rho times the product over the box's three axes of clamp((h_i - |p_i|) /
F, 0, 1), p the point in the box's frame, h its half extents and F = edge_fade times the
smallest half extent (F = 0: a hard box, rho inside). Along a ray each factor is piecewise
linear in the ray's parameter, with its kinks where the ray crosses the planes |p_i| = h_i
and |p_i| = h_i - F; the product is a cubic between consecutive kinks, so Simpson's rule on
each piece integrates it exactly (Kay and Kajiya's slab method finds the chord; the kinks
are the slabs' own crossings, sorted). The chord is taken about the ray's closest approach
to the box's centre, so that a thin box far away keeps its few centimetres (its entry and
exit distances, 1e4 m each, are not subtracted in float32).

A carving body (carve > 0) adds no fog: inside itself it removes the share carve of every
other layer's fog (kinds/carving.py), in CARVE_SHELLS nested boxes inset across its edge
fade.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

import numpy as np
from pydantic import ConfigDict, Field, model_validator

from fogbank.kinds.kind import Kind, Layout, exponential
from fogbank.kinds.rays import slide
from fogbank.model.fields import LayerBase, Position, num

# a half extent or a radius, m
Extent = Annotated[float, Field(strict=True, ge=0.01, le=10000)]
# a carving body's nested shells across its edge fade (1 without one): each removes
# carve / CARVE_SHELLS of the other layers' fog (kinds/carving.py)
CARVE_SHELLS = 4


class Oriented(LayerBase):
    """A body placed in the scene: centre and orientation (yaw about +y, then pitch about
    the body's x, then roll about its z), shared by the box and the ellipsoid."""
    center: Position = Field((0.0, 6.0, 0.0), description="m")
    yaw: float = num(0.0, -360, 360, 1, "deg", "turn about the vertical; positive turns +z toward +x")
    pitch: float = num(0.0, -180, 180, 1, "deg", "tilt about the body's x axis; positive tips its +y toward +z")
    roll: float = num(0.0, -180, 180, 1, "deg", "turn about the body's z axis")
    density: float = num(0.1, 0, 10, 0.001, "1/m", "density inside (see edge_fade)")
    carve: float = num(0.0, 0, 1, 0.01, "", "carving: above 0 the body adds no fog and removes this share of "
                       "every other layer's fog inside itself, and only there (1: a clear hole; its edge "
                       "fade softens it in steps)")

    @model_validator(mode="before")
    @classmethod
    def _negative_density(cls, data):
        if isinstance(data, dict) and isinstance(data.get("density"), (int, float)) and data["density"] < 0:
            raise ValueError(f"density = {data['density']:g}: a body's density is 0 or more. A negative "
                             "density took fog away along the whole ray; to carve fog out inside the body "
                             "only, set carve (0 to 1: the share of the other layers' fog it removes)")
        return data

    def axes(self) -> np.ndarray:
        """The body's unit axes as the rows of a 3x3 matrix (world -> body: R @ x)."""
        y, p, r = (math.radians(a) for a in (self.yaw, self.pitch, self.roll))
        Ry = np.array([[math.cos(y), 0, math.sin(y)], [0, 1, 0], [-math.sin(y), 0, math.cos(y)]])
        Rx = np.array([[1, 0, 0], [0, math.cos(p), -math.sin(p)], [0, math.sin(p), math.cos(p)]])
        Rz = np.array([[math.cos(r), -math.sin(r), 0], [math.sin(r), math.cos(r), 0], [0, 0, 1]])
        return (Ry @ Rx @ Rz).T   # columns of Ry Rx Rz are the body's axes in the world

    @property
    def carving(self) -> bool:
        return self.carve > 0


class Box(Oriented):
    """A box of density rho, its faces faded over edge_fade of its smallest half extent."""
    model_config = ConfigDict(title="Fog box")
    kind: Literal["box"] = "box"
    source = "fogbank: a box's chord by the slab method, its faces faded (Godot's FogVolume edge fade)"
    summary = ("A box of fog turned any way, its faces hard or soft: fog lying along a river, a bank of cloud. "
               "With carve it removes the other layers' fog inside itself instead.")
    formula = (r"\rho(\mathbf{x}) = \rho \prod_i \mathrm{clamp}\left(\frac{h_i - |p_i|}{F}, 0, 1\right), "
               r"\quad F = f \min_i h_i")
    half_size: tuple[Extent, Extent, Extent] = Field(
        (10.0, 4.0, 10.0), description="half extents along the box's x, y, z, m (each 0.01-10000)")
    edge_fade: float = num(0.0, 0, 1, 0.01, "", "soft faces: the density fades in over this share of the "
                           "smallest half extent inward from each face (0: hard faces)")

    def fade_width(self) -> float:
        """F (m): the fade's depth inward from each face."""
        return self.edge_fade * min(self.half_size)


def _local(layer, O, omega, t, env):
    """The rays in the body's frame: origins relative to the centre, and directions."""
    R = layer.axes()
    return (slide(layer, O, t, env.wind) - np.asarray(layer.center)) @ R.T, omega @ R.T


def fade(layer, p: np.ndarray) -> np.ndarray:
    """The box's profile at points p in its frame (N, 3): the product of the axes' ramps."""
    h, F = np.asarray(layer.half_size), layer.fade_width()
    if F <= 0:
        return np.all(np.abs(p) <= h, axis=1).astype(float)
    return np.prod(np.clip((h - np.abs(p)) / F, 0.0, 1.0), axis=1)


def density(layer, x, t, env):
    if layer.carving:
        return np.zeros(len(x))
    p, _ = _local(layer, x, x, t, env)
    return layer.density * fade(layer, p)


def slab_chord(o, v, h, d):
    """The parameter interval [s0, s1] of the rays o + v s (box frame), s in [0, d], inside
    |p_i| <= h_i (h (3,) or (N, 3)), taken about each ray's closest approach to the centre
    (float64: exact enough at any distance; the shader does the same in float32). s1 < s0
    where the ray misses."""
    h = np.broadcast_to(np.asarray(h, dtype=np.float64), o.shape)
    c = -np.einsum("ij,ij->i", o, v) / np.maximum(np.einsum("ij,ij->i", v, v), 1e-300)
    oc = o + v * c[:, None]   # the point nearest the centre
    lo, hi = np.full(len(o), -np.inf), np.full(len(o), np.inf)
    for i in range(3):
        par = v[:, i] == 0
        with np.errstate(divide="ignore", invalid="ignore"):
            ta = (-h[:, i] - oc[:, i]) / v[:, i]
            tb = (h[:, i] - oc[:, i]) / v[:, i]
        a = np.where(par, np.where(np.abs(oc[:, i]) <= h[:, i], -np.inf, np.inf), np.minimum(ta, tb))
        b = np.where(par, np.where(np.abs(oc[:, i]) <= h[:, i], np.inf, -np.inf), np.maximum(ta, tb))
        lo, hi = np.maximum(lo, a), np.minimum(hi, b)
    return np.maximum(lo, -c) + c, np.minimum(hi, d - c) + c, np.minimum(hi, d - c) - np.maximum(lo, -c)


def optical_depth(layer, O, omega, d, t, env):
    if layer.carving:
        return np.zeros(len(d))
    o, v = _local(layer, O, omega, t, env)
    h = np.asarray(layer.half_size)
    s0, s1, length = slab_chord(o, v, h, d.astype(np.float64))
    F = layer.fade_width()
    if F <= 0:
        return env.weight * layer.density * np.maximum(length, 0.0)
    # the kinks of each axis's ramp: where |o_i + v_i s| = h_i and = h_i - F
    with np.errstate(divide="ignore", invalid="ignore"):
        kinks = np.concatenate([(sgn * b - o[:, i:i + 1]) / v[:, i:i + 1]
                                for i in range(3) for sgn in (-1, 1) for b in (h[i], h[i] - F)], axis=1)
    kinks = np.where(np.isfinite(kinks), kinks, s0[:, None])
    pts = np.sort(np.concatenate([s0[:, None], np.clip(kinks, s0[:, None], np.maximum(s1, s0)[:, None]),
                                  np.maximum(s1, s0)[:, None]], axis=1), axis=1)
    a, b = pts[:, :-1], pts[:, 1:]

    def f(s):
        return fade(layer, (o[:, None, :] + v[:, None, :] * s[..., None]).reshape(-1, 3)).reshape(s.shape)
    simpson = (b - a) / 6.0 * (f(a) + 4.0 * f((a + b) / 2.0) + f(b))
    return np.where(length > 0, env.weight * layer.density * simpson.sum(axis=1), 0.0)


def shell_chords(layer, O, omega, d, t, env):
    """A carving box's nested boxes' chords along the rays: [(share, s0, s1)], the k-th
    inset by (k + 1/2) / K of the fade depth (K = CARVE_SHELLS, 1 without a fade)."""
    o, v = _local(layer, O, omega, t, env)
    F = layer.fade_width()
    k_all = CARVE_SHELLS if F > 0 else 1
    h = np.asarray(layer.half_size)
    out = []
    for k in range(k_all):
        inset = np.maximum(h - F * (k + 0.5) / k_all, 0.0) if F > 0 else h
        s0, s1, _ = slab_chord(o, v, inset, d.astype(np.float64))
        out.append((1.0 / k_all, s0, s1))
    return out


def pack_oriented(layer, p) -> dict:
    R = layer.axes()
    strength = layer.carve if layer.carving else p.density * layer.density
    return {"center": np.asarray(layer.center) - p.slid(layer), "density": strength,
            "axis_x": R[0], "axis_y": R[1], "axis_z": R[2]}


def sample_oriented(rng) -> dict:
    carve = float(rng.uniform(0.2, 1.0)) if rng.random() < 0.3 else 0.0
    return dict(center=tuple(rng.normal(size=3) * 8), yaw=rng.uniform(-180, 180),
                pitch=float(rng.choice([0.0, rng.uniform(-90, 90)])), roll=rng.uniform(-45, 45),
                density=float(rng.uniform(0, 0.3)), carve=carve, wind=bool(rng.random() < 0.5))


def carving_variant(layer) -> tuple:
    """A carving body's GLSL is its own (kinds/carving.py)."""
    return ("carve",) if layer.carving else ()


KIND = Kind(
    model=Box,
    layout=Layout("box", ("center", 3), ("density", 1), ("axis_x", 3), ("axis_y", 3), ("axis_z", 3),
                  ("half_size", 3), ("fade", 1)),
    pack=lambda layer, p: {**pack_oriented(layer, p), "half_size": layer.half_size, "fade": layer.fade_width()},
    code=exponential("boxOpticalDepth(Os, w, ds, {center}, {axis_x}, {axis_y}, {axis_z}, "
                     "{half_size}, {fade}, {density})"),
    carve_code=lambda r, v: (r.format("boxShellChord(Os, w, ds, {center}, {axis_x}, {axis_y}, {axis_z}, "
                                      "{half_size}, {fade}, k, shells)"), r.format("({fade} > 0.0 ? CARVE_SHELLS : 1)"),
                             r.density),
    density_code=lambda r, v: r.format(
        "rho *= 1.0 - {density} * boxCarveShare(x, {center}, {axis_x}, {axis_y}, {axis_z}, {half_size}, {fade});"
        if v else "rho += boxDensity(x, {center}, {axis_x}, {axis_y}, {axis_z}, {half_size}, {fade}, {density});"),
    variant=carving_variant,
    sample=lambda rng: Box(**sample_oriented(rng), half_size=tuple(rng.uniform(0.5, 15, 3)),
                           edge_fade=float(rng.choice([0.0, rng.uniform(0, 1)]))),
    optical_depth=optical_depth, density=density, shell_chords=shell_chords,
)
