"""Cosine fog (Biri 3.2.1): rho (c0 + sum c_i cos(k_i . x / scale + phi_i))."""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import ConfigDict, Field, model_validator

from fogbank.kinds.kind import Kind, Layout
from fogbank.kinds.rays import slide
from fogbank.kinds.reduce import EXACT_ABOVE, phase_at
from fogbank.model.fields import LayerBase, Strict, Wave, num, with_rules

MAX_COSINE_TERMS = 8


class CosineTerm(Strict):
    amp: float = num(0.5, -10, 10, 0.01, "", "amplitude c_i", title="amplitude cᵢ")
    k: tuple[Wave, Wave, Wave] = Field((0.0, 1.0, 0.0), title="wave vector kᵢ", description="wave vector, rad per function unit")
    phase: float = num(0.0, -1000, 1000, 0.01, "rad", "phase phi_i", title="phase φᵢ")


class Cosine(LayerBase):
    """Biri 3.2.1: density * (c0 + sum c_i cos(k_i . x / scale + phi_i))."""
    # x-rules: the validator's cross-field rule stated for the page, which keeps a control
    # inside it (static/controls.js keepRules): c0 is at least the sum of |amp|
    model_config = ConfigDict(title="Cosine layers", json_schema_extra=with_rules(
        {"field": "c0", "atLeast": {"sumAbs": ["terms", "amp"]},
         "why": "the constant c₀ is at least the sum of the |amplitudes|, so the density never goes negative"}))
    kind: Literal["cosine"] = "cosine"
    source = "Biri, Michelin & Arquès 2002, section 3.2.1"
    summary = "Bands and waves of fog from a sum of cosines, integrated exactly along each ray; the wind slides their phases."
    formula = r"\rho(\mathbf{x}) = \rho \left(c_0 + \sum_i c_i \cos\left(\frac{\mathbf{k}_i \cdot \mathbf{x}}{s} + \varphi_i\right)\right)"
    density: float = num(0.01, 0, 10, 0.0005, "1/m", "overall weight", title="density ρ")
    c0: float = num(1.0, 0, 100, 0.01, "", "constant term; at least the sum of |amplitude| (no negative density)", title="constant c₀")
    terms: list[CosineTerm] = Field(default_factory=lambda: [CosineTerm()],
                                    max_length=MAX_COSINE_TERMS)
    scale: float = num(20.0, 0.01, 10000, 0.5, "m", "scene metres per function unit", gt=True, title="scale s")

    @model_validator(mode="after")
    def _nonnegative(self) -> "Cosine":
        s = sum(abs(t.amp) for t in self.terms)
        if self.c0 < s:
            raise ValueError(f"c0 = {self.c0} must be >= the sum of |amp| = {s:g} "
                             "(Biri 3.2.1) so that the density stays >= 0")
        return self


def density(layer, x, t, env):
    x = slide(layer, x, t, env.wind) / layer.scale
    s = np.full(len(x), layer.c0)
    for term in layer.terms:
        s = s + term.amp * np.cos(x @ np.asarray(term.k) + term.phase)
    return layer.density * s


def _phases(term, layer, O, t, wind):
    """Each ray's phase k . (O - wind t) / scale + phase, reduced to [-pi, pi) (exactly where
    it is large: late times, fine waves), as kinds/packing.py (phase_at) reduces it for the shader."""
    w = np.asarray(wind, dtype=np.float64) if layer.wind else np.zeros(3)
    k = np.asarray(term.k, dtype=np.float64)
    x = ((O - w[None, :] * t[:, None]) @ k) / layer.scale + term.phase
    big = (np.abs(O) + np.abs(w)[None, :] * t[:, None]) @ np.abs(k) / layer.scale + abs(term.phase)
    A = x - 2 * np.pi * np.floor(x / (2 * np.pi) + 0.5)
    for i in np.nonzero(big >= EXACT_ABOVE)[0]:
        A[i] = phase_at(k, O[i], w, float(t[i]), layer.scale, term.phase)
    return A


def optical_depth(layer, O, omega, d, t, env):
    # integral of cos(A + B s) over [0, d] = d cos(A + B d / 2) sinc(B d / 2)
    tau = layer.c0 * d
    for term in layer.terms:
        k = np.asarray(term.k, dtype=np.float64)
        A = _phases(term, layer, O, t, env.wind)
        B = (omega @ k) / layer.scale
        h = B * d / 2.0
        tau = tau + term.amp * d * np.cos(A + h) * np.sinc(h / np.pi)
    return env.weight * layer.density * tau


def pack(layer, p):
    # each term's phase at E (wind slide included), reduced to [-pi, pi) in float64
    terms = [(*t.k, phase_at(t.k, p.ref, p.wind(layer), p.time, layer.scale, t.phase))
             for t in layer.terms]
    return {"density": p.density * layer.density, "c0": layer.c0, "inv_scale": 1.0 / layer.scale,
            "terms": np.ravel(terms), "amps": [t.amp for t in layer.terms]}


def split_by_time(layer, v):
    """A term whose wave vector is across the velocity (k . v = 0, e.g. a vertical wave
    under a level wind) has the same phase at every time: (the constant and those terms,
    without wind; the other terms, with no constant), whose optical depths add up to the
    layer's (each term's integral is its own, Biri 3.2.1). The moving part's c0 = 0 is
    below the sum of its |amp|: it is never drawn alone, only added to the other part."""
    across = [float(np.dot(t.k, v)) == 0.0 for t in layer.terms]
    still = [t for t, a in zip(layer.terms, across) if a]
    if not still:
        return None, layer
    moving = [t for t, a in zip(layer.terms, across) if not a]
    # without wind its packing is the same at every time (no phase that rounds differently)
    still_part = layer.model_copy(update={"terms": still, "wind": False})
    return still_part, (layer.model_copy(update={"terms": moving, "c0": 0.0}) if moving else None)


def code(r, variant):
    (n,) = variant
    body = [f"float acc = {r.c0} * ds;", f"vec3 Ou = Os * {r.inv_scale};", f"vec3 wu = w * {r.inv_scale};"]
    for j in range(n):
        body.append(f"acc += cosineTermOpticalDepth(Ou, wu, ds, {r.at('terms', j)}.xyz, "
                    f"{r.at('terms', j)}.w, {r.at('amps', j)});")
    body.append(f"tau += {r.density} * acc;")
    return "{ " + " ".join(body) + " }"


def density_code(r, variant):
    (n,) = variant
    t = " + ".join(f"cosineTermDensity(x * {r.inv_scale}, {r.at('terms', j)}.xyz, "
                   f"{r.at('terms', j)}.w, {r.at('amps', j)})" for j in range(n)) or "0.0"
    return f"rho += {r.density} * ({r.c0} + {t});"


def sample(rng):
    n = int(rng.integers(1, 6))
    terms = [CosineTerm(amp=rng.uniform(-1, 1), k=tuple(rng.normal(size=3) * 3),
                        phase=rng.uniform(-3, 3)) for _ in range(n)]
    c0 = sum(abs(t.amp) for t in terms) + rng.uniform(0, 1)
    return Cosine(density=rng.uniform(0, 0.03), c0=c0, terms=terms, scale=rng.uniform(2, 40),
                  wind=bool(rng.random() < 0.5))


KIND = Kind(
    model=Cosine,
    layout=Layout("cosine", ("density", 1), ("c0", 1), ("inv_scale", 1),
                  ("terms", 4, MAX_COSINE_TERMS), ("amps", 1, MAX_COSINE_TERMS)),
    pack=pack, code=code, density_code=density_code, sample=sample,
    optical_depth=optical_depth, density=density,
    variant=lambda layer: (len(layer.terms),),
    seconds_per_mpx=0.02,
    extra_seconds=lambda layer, fog_mpx: 0.01 * len(layer.terms) * fog_mpx,
    describe=lambda layer: f"cosine, {len(layer.terms)} terms",
    jit_units=lambda variant: 1.5 * variant[0],
    split_by_time=split_by_time,
)
