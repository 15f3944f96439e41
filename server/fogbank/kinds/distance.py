"""Distance fog (Gawron 3.1, 3.3): F = clamp(N ((d - start) / D)^e, 0, max), T = 1 - F."""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import ConfigDict

from fogbank.kinds import noise_bake as bake
from fogbank.kinds.kind import Kind, Layout, direct
from fogbank.kinds.rays import slide
from fogbank.model.fields import Drift, LayerBase, drift_field, num


class Distance(LayerBase):
    """Gawron 3.1/3.3: F = clamp(N ((d - start)/D)^e, 0, max), N = lerp(low, high, noise)."""
    model_config = ConfigDict(title="Distance fog")
    kind: Literal["distance"] = "distance"
    source = "Gawron & Boryczka 2018, sections 3.1 and 3.3"
    summary = "Fog that grows with distance from the eye, its amount varied by moving noise."
    formula = r"F = \mathrm{clamp}\left(N \left(\frac{d - d_s}{D}\right)^{e}, 0, F_{max}\right), \quad T = 1 - F"
    start: float = num(0.0, 0, 10000, 1, "m", "no fog nearer than this (Gawron's StartDistance)", title="start dₛ")
    distance: float = num(300.0, 0.1, 100000, 1, "m", "blend distance: F reaches N here", gt=True, title="blend distance D")
    exponent: float = num(0.55, 0.01, 10, 0.01, "", "falloff exponent: below 1 the fog comes in early", gt=True, title="exponent e")
    low: float = num(0.9, 0, 10, 0.01, "", "density where noise = 0")
    high: float = num(1.3, 0, 10, 0.01, "", "density where noise = 1")
    max: float = num(0.6, 0, 1, 0.01, "", "largest fog amount F", title="max fog F_max")
    noise_scale: float = num(80.0, 0.1, 10000, 0.5, "m", "size of one noise tile", gt=True)
    drift: Drift = drift_field()


def transmittance(layer, O, omega, d, t, env):
    P = O + omega * d[:, None]
    n = bake.sample(env.tex, slide(layer, P, t, env.wind), layer.noise_scale)
    N = layer.low + (layer.high - layer.low) * n
    x = np.maximum(d - layer.start, 0.0) / layer.distance
    F = np.clip(N * x**layer.exponent, 0.0, layer.max)
    return 1.0 - F


def log_transmittance(layer, O, omega, d, t, env):
    with np.errstate(divide="ignore"):
        return np.log(transmittance(layer, O, omega, d, t, env))


def sample(rng):
    return Distance(start=rng.uniform(0, 30), distance=rng.uniform(20, 400), exponent=rng.uniform(0.2, 3),
                    low=rng.uniform(0, 1), high=rng.uniform(0, 2), max=rng.uniform(0, 1),
                    noise_scale=rng.uniform(5, 100), wind=bool(rng.random() < 0.5),
                    drift=tuple(rng.uniform(-3, 3, 3)) if rng.random() < 0.5 else (0.0, 0.0, 0.0))


KIND = Kind(
    model=Distance,
    layout=Layout("distance", ("start", 1), ("inv_distance", 1), ("exponent", 1), ("max", 1),
                  ("low", 1), ("high", 1), ("inv_noise_scale", 1), ("offset", 3)),
    pack=lambda layer, p: {
        "start": layer.start, "inv_distance": 1.0 / layer.distance, "exponent": layer.exponent,
        "max": layer.max, "low": layer.low, "high": layer.high,
        "inv_noise_scale": 1.0 / layer.noise_scale,
        "offset": np.mod(p.slid(layer) / layer.noise_scale, 1.0)},   # E in tiles, mod 1
    code=direct("distanceFogAmount(ds, noiseSample(uNoise, P, {inv_noise_scale}, {offset}, true), "
                "{start}, {inv_distance}, {exponent}, {max}, {low}, {high})"),
    sample=sample, log_transmittance=log_transmittance, uses_noise=True, seconds_per_mpx=0.05,
)
