"""Tiled polynomial fog (Biri 3.2.2): rho P(u), u = a . x + b on [-C, C].

Outside [-C, C] the tile repeats, is mirrored at each border, or is zero. Biri warns that
a repeated tile needs "the same value in the border"; the paper's own {0.8, -1, 0, 0, 1}
does not have it (P(-1) = 2.8, P(1) = 0.8), so repeat mode refuses such coefficients and
mirror mode (the default) keeps them seamless: tile n is P(r) for even n, P(-r) for odd n,
r = u - 2Cn, continuous at every border by construction and periodic in 4C."""

from __future__ import annotations

import math
from typing import Annotated, Literal

import numpy as np
from numpy.polynomial import polynomial as npoly
from pydantic import ConfigDict, Field, model_validator

from fogbank.kinds.kind import Kind, Layout
from fogbank.kinds.rays import slide
from fogbank.kinds.reduce import EXACT_ABOVE, coordinate_at, taylor_shift
from fogbank.model.fields import LayerBase, Wave, num

MAX_POLY_COEFFS = 8
# a coefficient: finite, |c| <= 1e6 (the schema states it; P's float32 sums stay exact enough)
Coeff = Annotated[float, Field(strict=True, ge=-1e6, le=1e6)]


def poly_min(coeffs: list[float], lo: float, hi: float) -> float:
    """Minimum of sum coeffs[i] u^i on [lo, hi] (endpoints and real critical points)."""
    c = np.asarray(coeffs, dtype=np.float64)
    cands = [lo, hi]
    if len(c) > 2:
        d = np.polynomial.polynomial.polyder(c)
        if np.any(d != 0):
            for r in np.polynomial.polynomial.polyroots(np.trim_zeros(d, "b")):
                if abs(r.imag) < 1e-9 and lo <= r.real <= hi:
                    cands.append(float(r.real))
    return float(min(np.polynomial.polynomial.polyval(cands, c)))


class Polynomial(LayerBase):
    """Biri 3.2.2: density * P(u), u = axis . x + offset, on [-C, C], tiled or zero outside."""
    model_config = ConfigDict(title="Polynomial tiles")
    kind: Literal["polynomial"] = "polynomial"
    source = "Biri, Michelin & Arquès 2002, section 3.2.2"
    summary = "Fog shaped by a polynomial over one tile along an axis, mirrored or repeated across the scene."
    formula = r"\rho(\mathbf{x}) = \rho\, P(u), \quad P(u) = \sum_i p_i u^i, \quad u = \mathbf{a} \cdot \mathbf{x} + b \in [-C, C]"
    density: float = num(0.02, 0, 10, 0.0005, "1/m", "weight c_i", title="density ρ")
    coeffs: list[Coeff] = Field([0.8, -1.0, 0.0, 0.0, 1.0], min_length=1,
                                max_length=MAX_POLY_COEFFS, title="coefficients pᵢ",
                                description="P(u) = sum coeffs[i] u^i (ascending powers)")
    axis: tuple[Wave, Wave, Wave] = Field((1.0 / 60.0, 0.0, 0.0), title="axis a", description="u = axis . x + offset, 1/m")
    offset: float = num(0.0, -1000, 1000, 0.01, "", "added to u", title="offset b")
    half_width: float = num(1.0, 1e-3, 1000, 0.01, "", "C: P is defined on [-C, C]", gt=True, title="half width C")
    mode: Literal["mirror", "repeat", "zero"] = Field(
        "mirror", description="outside [-C, C]: mirror the tile at each border (seamless), repeat it "
                              "(needs P(-C) = P(C)), or zero")

    @model_validator(mode="after")
    def _nonnegative(self) -> "Polynomial":
        for i, c in enumerate(self.coeffs):
            if not math.isfinite(c) or abs(c) > 1e6:
                raise ValueError(f"coeffs[{i}] must be finite with |c| <= 1e6")
        m = poly_min(self.coeffs, -self.half_width, self.half_width)
        if m < -1e-9:
            raise ValueError(f"P(u) reaches {m:.4g} < 0 on [-C, C] = [-{self.half_width:g}, "
                             f"{self.half_width:g}]; a density must be >= 0 (Biri 3.2.2)")
        if self.mode == "repeat":
            left, right = (float(npoly.polyval(x, self.coeffs)) for x in (-self.half_width, self.half_width))
            scale = float(np.sum(np.abs(self.coeffs) * self.half_width ** np.arange(len(self.coeffs))))
            if abs(left - right) > BORDER_TOLERANCE * scale:
                raise ValueError(
                    f"in repeat mode P(-C) and P(C) must be equal, or each tile border shows a "
                    f"seam (Biri 3.2.2); here P(-{self.half_width:g}) = {left:.6g} and "
                    f"P({self.half_width:g}) = {right:.6g}. Use mode 'mirror', which is "
                    f"seamless for any coefficients, or coefficients with equal border values")
        return self


# |P(C) - P(-C)| allowed in repeat mode, as a share of sum |c_i| C^i: the rounding of
# coefficients typed with 9 or more digits, far below one level of 8-bit colour
BORDER_TOLERANCE = 1e-9


def period_of(layer) -> float | None:
    """The length in u after which the tiled P repeats: 2C (repeat), 4C (mirror), none (zero)."""
    C = layer.half_width
    return {"repeat": 2 * C, "mirror": 4 * C}.get(layer.mode)


def _tiled(layer, u):
    """Map u into the reference interval [-C, C): (r, tile n, inside); in mirror mode an
    odd tile is reflected (r -> -r); in zero mode u stays and `inside` flags [-C, C]."""
    C = layer.half_width
    if layer.mode == "zero":
        return u, np.zeros_like(u), (u >= -C) & (u <= C)
    n = np.floor((u + C) / (2 * C))
    r = u - 2 * C * n
    if layer.mode == "mirror":
        r = np.where(n % 2 == 1, -r, r)
    return r, n, np.ones_like(u, dtype=bool)


def density(layer, x, t, env):
    u = slide(layer, x, t, env.wind) @ np.asarray(layer.axis) + layer.offset
    r, _, inside = _tiled(layer, u)
    return layer.density * np.where(inside, npoly.polyval(r, layer.coeffs), 0.0)


def mean(layer, u0, u1):
    """The mean of P over [u0, u1] (P(u0) where they meet): sum c_i/(i+1) D_i with
    D_i = (u1^(i+1) - u0^(i+1)) / (u1 - u0) = sum_j u0^j u1^(i-j), built as
    D_i = u1 D_(i-1) + u0^i: products and sums, no difference of antiderivatives."""
    D = np.ones_like(u0)
    p = np.ones_like(u0)
    acc = np.full_like(u0, layer.coeffs[0])
    for i, c in enumerate(layer.coeffs[1:], start=1):
        p = p * u0
        D = u1 * D + p
        acc = acc + c / (i + 1) * D
    return acc


def optical_depth(layer, O, omega, d, t, env):
    # as kinds/polynomial.glsl: the ray's u-interval [lo, hi] integrated tile by
    # tile (the partial tile at each end, whole tiles between), each piece its length
    # times P's mean over it; tau = density d * integral / (hi - lo), or d P(u) if flat.
    # In mirror mode u0 is reduced by whole periods of 4C, so a tile's parity is kept.
    a = np.asarray(layer.axis, dtype=np.float64)
    C = layer.half_width
    tiled = layer.mode != "zero"
    period = period_of(layer)
    w = np.asarray(env.wind, dtype=np.float64) if layer.wind else np.zeros(3)
    x = (O - w[None, :] * t[:, None]) @ a + layer.offset
    big = (np.abs(O) + np.abs(w)[None, :] * t[:, None]) @ np.abs(a) + abs(layer.offset)
    u0 = x - period * np.floor((x + C) / period) if tiled else x
    for i in np.nonzero(big >= EXACT_ABOVE)[0]:   # exactly, where float64 would lose digits
        u0[i] = coordinate_at(a, O[i], w, float(t[i]), layer.offset, period, C)
    u1 = u0 + (omega @ a) * d
    lo, hi = np.minimum(u0, u1), np.maximum(u0, u1)
    span = hi - lo
    flat = span == 0
    safe = np.where(flat, 1.0, span)
    if not tiled:
        left, right = np.maximum(lo, -C), np.minimum(hi, C)
        inside = right >= left
        frac = np.where(flat, 1.0, np.clip(right - left, 0.0, None) / safe)
        m = mean(layer, np.where(inside, left, 0.0), np.where(inside, right, 0.0))
        return env.weight * layer.density * d * np.where(inside, frac * m, 0.0)
    n0, n1 = np.floor((lo + C) / (2 * C)), np.floor((hi + C) / (2 * C))
    r0 = np.clip(lo - 2 * C * n0, -C, C)
    r1 = np.clip(hi - 2 * C * n1, -C, C)
    Q = npoly.polyint(layer.coeffs)
    tile = npoly.polyval(C, Q) - npoly.polyval(-C, Q)
    mirror = layer.mode == "mirror"

    def tile_mean(n, a, b):   # the mean of tile n's P over its own [a, b] (reflected if odd)
        odd = mirror & (n % 2 == 1)
        return mean(layer, np.where(odd, -b, a), np.where(odd, -a, b))
    one = tile_mean(n0, r0, r1)
    whole = ((C - r0) * tile_mean(n0, r0, np.full_like(r0, C)) + (n1 - n0 - 1) * tile
             + (r1 + C) * tile_mean(n1, np.full_like(r1, -C), r1)) / safe
    return env.weight * layer.density * d * np.where(n0 == n1, one, whole)


def pack(layer, p):
    C = layer.half_width
    c = np.zeros(MAX_POLY_COEFFS)
    c[:len(layer.coeffs)] = layer.coeffs
    Q = npoly.polyint(c)  # Q[0] = 0, Q[i+1] = c_i / (i + 1)
    tile = npoly.polyval(C, Q) - npoly.polyval(-C, Q)
    u0 = coordinate_at(layer.axis, p.ref, p.wind(layer), p.time, layer.offset, period_of(layer), C)
    # P about the point where the reference is (kept inside [-C, C] in zero mode), so a
    # short ray near a root does not cancel large terms (polynomial.glsl). In mirror mode
    # u0 lies in [-C, 3C): in tile 1 the tiled P is P(2C - u), so about u0 it is
    # P((2C - u0) - v), P's expansion about 2C - u0 with its odd powers negated.
    e = min(max(u0, -C), C)
    own = 1.0 if layer.mode == "mirror" and u0 >= C else 0.0   # the reference's own tile
    shifted = taylor_shift(c, 2 * C - u0) * (-1.0) ** np.arange(len(c)) if own else taylor_shift(c, e)
    n = np.arange(1, MAX_POLY_COEFFS + 1)
    return {"axis": layer.axis, "u0": u0, "density": p.density * layer.density, "C": C,
            "tiling": TILING[layer.mode], "period": tile, "coeffs": c,
            "integral": Q[1:], "shifted": shifted / n, "shift": (e - u0 if not own else 0.0, e, own)}


TILING = {"zero": 0.0, "repeat": 1.0, "mirror": 2.0}   # the shader's `tiling`


def sample(rng):
    C = rng.uniform(0.3, 2)
    while True:
        coeffs = list(rng.normal(size=int(rng.integers(1, 7))))
        lo = poly_min(coeffs, -C, C)
        if lo < 0:
            coeffs[0] -= lo - rng.uniform(0, 0.5)
        if poly_min(coeffs, -C, C) >= 0:
            break
    mode = str(rng.choice(["mirror", "repeat", "zero"]))
    if mode == "repeat" and len(coeffs) > 1:
        # equal border values: the odd powers sum to 0 at C (c_1 C = -sum_(odd i > 1) c_i C^i)
        coeffs[1] = -sum(coeffs[i] * C ** (i - 1) for i in range(3, len(coeffs), 2))
        lo = poly_min(coeffs, -C, C)
        coeffs[0] -= min(lo, 0.0)
    return Polynomial(density=rng.uniform(0, 0.03), coeffs=coeffs, half_width=C,
                      axis=tuple(rng.normal(size=3) / 15), offset=rng.uniform(-2, 2),
                      mode=mode, wind=bool(rng.random() < 0.5))


KIND = Kind(
    model=Polynomial,
    layout=Layout("polynomial", ("axis", 3), ("u0", 1), ("density", 1), ("C", 1), ("tiling", 1),
                  ("period", 1), ("coeffs", 1, MAX_POLY_COEFFS), ("integral", 1, MAX_POLY_COEFFS),
                  ("shifted", 1, MAX_POLY_COEFFS), ("shift", 3)),
    pack=pack,
    code=lambda r, v: f"tau += {r.density} * polynomialOpticalDepth(Os, w, ds, {r.axis}, {r.u0}, "
                      f"{r.C}, {r.tiling}, {r.period}, {r.group('integral', 0)}, "
                      f"{r.group('integral', 1)}, {r.group('shifted', 0)}, {r.group('shifted', 1)}, "
                      f"{r.shift});",
    density_code=lambda r, v: f"rho += {r.density} * polynomialDensity(x, {r.axis}, {r.u0}, {r.C}, "
                              f"{r.tiling}, {r.group('coeffs', 0)}, {r.group('coeffs', 1)});",
    sample=sample, optical_depth=optical_depth, density=density,
)
