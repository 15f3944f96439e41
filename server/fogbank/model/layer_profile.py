"""The function editor's data (POST /api/layers/profile), after Biri 2002's Fig. 2, "the
application used to define fog density with polynomials": a polynomial or cosine layer's
density along its axis, the points the user drags to shape it, the coefficients that
follow from the points, and the rules a shape would break, before it is sent.

- polynomial: P(u) over three tiles [-3C, 3C] (the tile and a neighbour each side, as
  the mode tiles it); the density is the layer's density times it ("shape"). The points are P at n + 1 evenly spaced
  u in [-C, C] (n the degree); the coefficients are the polynomial through them
  (numpy's float64 polyfit, exact for n + 1 points).
- cosine: c0 + sum c_i cos(...) along the first term's wave vector (metres from the
  origin), over two periods of that term; the density is the layer's density times it. The points are rho / density at 2 (terms + 1) evenly spaced
  positions over one period; c0 and the amplitudes follow by least squares (float64,
  the wave vectors and phases kept).

The shape comes from each kind's float64 density (kinds/<kind>.py) at density 1, time 0
and no wind: the function itself. Rules (each named, with where it breaks):
- "negative": the density goes below 0 somewhere (Biri 3.2.1, 3.2.2: a density is >= 0);
- "jump": in repeat mode, P(-C) != P(C), a step at every tile border (Biri 3.2.2).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.polynomial import polynomial as npoly
from pydantic import ValidationError

from fogbank.kinds import KINDS
from fogbank.kinds.kind import Env
from fogbank.kinds.polynomial import BORDER_TOLERANCE, poly_min

KINDS_EDITED = ("polynomial", "cosine")
SAMPLES = 241


def _density(layer, x: np.ndarray) -> np.ndarray:
    return KINDS[layer.kind].density(layer, x, np.zeros(len(x)), Env(wind=np.zeros(3)))


def _polynomial(layer, points: list[float] | None) -> dict[str, Any]:
    C = layer.half_width
    n = len(layer.coeffs) - 1
    knots = np.linspace(-C, C, n + 1) if n else np.array([0.0])
    coeffs = np.asarray(layer.coeffs, dtype=np.float64)
    if points is not None:
        if len(points) != len(knots):
            raise ValueError(f"points: {len(knots)} values (P at u = {', '.join(f'{k:g}' for k in knots)}), "
                             f"got {len(points)}")
        coeffs = npoly.polyfit(knots, np.asarray(points, dtype=np.float64), n) if n else np.array([points[0]])
    # the shape in u alone: the same layer with u = x (axis (1, 0, 0), no offset), density 1
    shaped = layer.model_construct(**{**dict(layer), "coeffs": [float(c) for c in coeffs], "density": 1.0,
                                      "axis": (1.0, 0.0, 0.0), "offset": 0.0, "wind": False})
    u = np.linspace(-3 * C, 3 * C, SAMPLES)
    x = np.stack([u, np.zeros_like(u), np.zeros_like(u)], axis=1)
    problems = []
    low = poly_min(list(coeffs), -C, C)
    if low < -1e-9:
        grid = np.linspace(-C, C, 2001)
        at = float(grid[np.argmin(npoly.polyval(grid, coeffs))])
        problems.append({"rule": "negative", "at": at, "value": float(low),
                         "msg": f"P(u) reaches {low:.4g} < 0 at u = {at:.3g}: a density must be >= 0 (Biri 3.2.2)"})
    if layer.mode == "repeat":
        left, right = (float(npoly.polyval(v, coeffs)) for v in (-C, C))
        scale = float(np.sum(np.abs(coeffs) * C ** np.arange(len(coeffs))))
        if abs(left - right) > BORDER_TOLERANCE * scale:
            problems.append({"rule": "jump", "at": C, "value": right - left,
                             "msg": f"repeat mode: P(-C) = {left:.4g} but P(C) = {right:.4g}, a jump at every "
                                    "tile border (Biri 3.2.2); use mirror mode or equal border values"})
    return {"kind": "polynomial", "axis_label": "u = axis · x + offset", "u": u.tolist(),
            "shape": _density(shaped, x).tolist(),
            "tile": [-C, C], "points": [[float(k), float(v)] for k, v in zip(knots, npoly.polyval(knots, coeffs))],
            "fitted": {"coeffs": [float(c) for c in coeffs]}, "problems": problems}


def _cosine(layer, points: list[float] | None) -> dict[str, Any]:
    k1 = np.asarray(layer.terms[0].k, dtype=np.float64) if layer.terms else np.array([1.0, 0.0, 0.0])
    kn = float(np.linalg.norm(k1))
    direction = k1 / kn if kn > 0 else np.array([1.0, 0.0, 0.0])
    period = 2 * np.pi * layer.scale / kn if kn > 0 else 100.0
    m = 2 * (len(layer.terms) + 1)
    knots = np.linspace(0.0, period, m, endpoint=False)
    basis = np.stack([np.ones(m)] + [np.cos((knots[:, None] * direction[None, :] / layer.scale) @ np.asarray(t.k)
                                            + t.phase) for t in layer.terms], axis=1)
    c = np.array([layer.c0] + [t.amp for t in layer.terms], dtype=np.float64)
    if points is not None:
        if len(points) != m:
            raise ValueError(f"points: {m} values (rho / density at {m} positions over one period), got {len(points)}")
        c = np.linalg.lstsq(basis, np.asarray(points, dtype=np.float64), rcond=None)[0]
    terms = [t.model_copy(update={"amp": float(a)}) for t, a in zip(layer.terms, c[1:])]
    shaped = layer.model_construct(**{**dict(layer), "c0": float(c[0]), "terms": terms, "density": 1.0, "wind": False})
    s = np.linspace(0.0, 2 * period, SAMPLES)
    rho = _density(shaped, s[:, None] * direction[None, :])
    problems = []
    if c[0] < float(np.sum(np.abs(c[1:]))):   # exactly the model's rule (no tolerance)
        at = float(s[np.argmin(rho)])
        problems.append({"rule": "negative", "at": at, "value": float(rho.min()),
                         "msg": f"c0 = {c[0]:.4g} is below the sum of |amplitudes| = {np.sum(np.abs(c[1:])):.4g}: "
                                "the density can go below 0 (Biri 3.2.1)"})
    return {"kind": "cosine", "axis_label": "m along the first wave", "u": s.tolist(), "shape": rho.tolist(),
            "tile": [0.0, float(period)],
            "points": [[float(k), float(v)] for k, v in zip(knots, basis @ c)],
            "fitted": {"c0": float(c[0]), "terms": [t.model_dump(mode="json") for t in terms]},
            "problems": problems}


def profile(layer, points: list[float] | None = None) -> dict[str, Any]:
    """The editor's view of `layer` (a validated polynomial or cosine layer), reshaped
    through `points` when given (values at the returned points' positions). Whatever
    else the layer's model refuses in the fitted coefficients (a value out of its range:
    c0 over 100, an amplitude over 10, a coefficient over 1e6 from a fit on a tiny tile)
    is a problem too ("range"), so that nothing the editor offers is refused when sent."""
    if layer.kind == "polynomial":
        out = _polynomial(layer, points)
    elif layer.kind == "cosine":
        out = _cosine(layer, points)
    else:
        raise ValueError(f"layer.kind = {layer.kind!r}: the editor shapes {' and '.join(KINDS_EDITED)} layers")
    if not out["problems"]:
        try:
            type(layer).model_validate({**layer.model_dump(mode="json"), **out["fitted"]})
        except ValidationError as exc:
            e = exc.errors(include_url=False)[0]
            at = ".".join(str(x) for x in e["loc"])
            out["problems"].append({"rule": "range", "at": None, "value": None,
                                    "msg": f"{at}: {e['msg']}" if at else e["msg"]})
    return out
