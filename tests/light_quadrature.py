"""An independent float64 truth for the sunlight that fog scatters toward the eye along a
ray (single scattering), written apart from the shader and from the closed forms:

    J = integral over s in [0, d] of sigma(s) T(0, s) T_sun(s) V(s) ds,

sigma the summed density of the density layers (each kind's float64 density, the model's
definition), T(0, s) = exp(-integral of sigma from the eye to s) integrated here
cumulatively on a fine grid (not by the closed forms), T_sun(s) the same density
integrated toward the sun from the point by composite Gauss-Legendre (LIT; else 1), and
V(s) whether the point sees the sun past the scene: an occluder given by the caller
(analytic boxes, or the shadow map read back and stated as the occluder).

The ray is cut at `points` fine points spread evenly in sqrt(s) (finer near the eye,
where each metre weighs most), and every piece over which T falls by more than REFINE_DT
is cut again (a dense body's face: its light comes from its first centimetres). T and the
midpoints' T_sun V are taken there, and J is the sum over the pieces of (T(s_i) -
T(s_i+1)) times the midpoint's T_sun V: exact for a constant T_sun V, and converging as
the pieces shrink (a shadow's edge errs by at most one piece's share of the fog)."""

from __future__ import annotations

import numpy as np

from fogbank.kinds import KINDS
from fogbank.kinds.kind import Env
from fogbank.kinds.reference import noise_tex

GL_NODES, GL_WEIGHTS = np.polynomial.legendre.leggauss(16)
REFINE_DT = 2e-3     # a piece of the ray whose T falls by more than this is cut again ...
REFINE_CUTS = 32     # ... into this many ...
REFINE_LEVELS = 4    # ... at most this many times (to 1e-6 of a first piece)


def density(fog, x: np.ndarray, t: float) -> np.ndarray:
    """sigma at the points x (N, 3), 1/m, the global density inside: the density layers'
    own float64 densities, summed, kept at 0 or more (a carving body's negative density)."""
    tex = noise_tex(fog) if any(l.enabled and KINDS[l.kind].uses_noise for l in fog.layers) else None
    env = Env(wind=fog.wind.vector(), weight=fog.density, tex=tex)
    rho = np.zeros(len(x))
    for layer in fog.layers:
        kind = KINDS[layer.kind]
        if layer.enabled and kind.optical_depth is not None:
            if kind.density is None:
                raise ValueError(f"kind {layer.kind!r} has no float64 density to integrate")
            rho += kind.density(layer, x, np.full(len(x), t), env)
    return np.maximum(rho, 0.0) * fog.density


def _edges(length: float, first: float = 0.5) -> np.ndarray:
    """[0, length] cut into pieces doubling from `first` metres: composite Gauss-Legendre
    on each follows a density that changes fastest near the ray's start (a height layer
    the sun's ray climbs out of)."""
    e = [0.0]
    step = first
    while e[-1] < length:
        e.append(min(length, e[-1] + step))
        step *= 1.5
    return np.array(e)


def sun_transmittance(fog, x: np.ndarray, t: float, sun_dir, sun_distance: float) -> np.ndarray:
    """T toward the sun from each point of x (N, 3) over sun_distance metres."""
    edges = _edges(sun_distance)
    a, b = edges[:-1], edges[1:]
    u = ((b - a)[:, None] * (GL_NODES[None, :] + 1.0) / 2.0 + a[:, None]).ravel()       # nodes along the ray
    wgt = ((b - a)[:, None] * GL_WEIGHTS[None, :] / 2.0).ravel()
    L = np.asarray(sun_dir, dtype=np.float64)
    tau = np.zeros(len(x))
    for lo in range(0, len(x), 512):
        pts = x[lo:lo + 512, None, :] + u[None, :, None] * L[None, None, :]
        rho = density(fog, pts.reshape(-1, 3), t).reshape(len(pts), len(u))
        tau[lo:lo + 512] = rho @ wgt
    return np.exp(-tau)


def single_scattering(fog, eye, w, d: float, t: float, visible, *, lit: bool, sun_distance: float,
                      points: int = 3000) -> tuple[float, float]:
    """(J, T(0, d)) along the ray eye + w s, s in [0, d]. `visible(x)` -> V in [0, 1] for
    points x (N, 3)."""
    eye = np.asarray(eye, dtype=np.float64)
    w = np.asarray(w, dtype=np.float64)
    s = d * np.linspace(0.0, 1.0, points + 1) ** 2
    for level in range(REFINE_LEVELS + 1):
        x = eye + s[:, None] * w
        rho = density(fog, x, t)
        tau = np.concatenate([[0.0], np.cumsum((rho[1:] + rho[:-1]) / 2.0 * np.diff(s))])   # trapezoid
        T = np.exp(-tau)
        # a piece over which T falls by more than REFINE_DT (a dense body's face, a thin
        # dense layer) is cut REFINE_CUTS times again, to resolve where its light comes from
        coarse = np.flatnonzero(np.abs(np.diff(T)) > REFINE_DT)
        if not len(coarse) or level == REFINE_LEVELS:
            break
        inner = (s[coarse, None] + np.diff(s)[coarse, None] * np.arange(1, REFINE_CUTS)[None, :] / REFINE_CUTS)
        s = np.sort(np.concatenate([s, inner.ravel()]))
    mid = eye + ((s[1:] + s[:-1]) / 2.0)[:, None] * w
    g = np.asarray(visible(mid), dtype=np.float64)
    if lit:
        g = g * sun_transmittance(fog, mid, t, fog.sun.direction(), sun_distance)
    return float(np.sum((T[:-1] - T[1:]) * g)), float(T[-1])


def boxes_visible(boxes, sun_dir):
    """V for the calibration scene: 0 where the point's ray toward the sun enters one of
    the axis-aligned boxes (lo, hi), slab by slab; the ground is a plane under a sun above
    the horizon, which shadows nothing above it."""
    L = np.asarray(sun_dir, dtype=np.float64)

    def visible(x):
        blocked = np.zeros(len(x), bool)
        for lo, hi in boxes:
            with np.errstate(divide="ignore", invalid="ignore"):
                t0, t1 = (np.asarray(lo) - x) / L, (np.asarray(hi) - x) / L
            enter, leave = np.nanmax(np.minimum(t0, t1), axis=1), np.nanmin(np.maximum(t0, t1), axis=1)
            blocked |= (enter <= leave) & (leave > 0)
        return (~blocked).astype(float)
    return visible
