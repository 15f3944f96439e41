"""Height fog (Unreal/Filament): rho exp(-k (y - h0))."""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import ConfigDict

from fogbank.kinds.kind import Kind, Layout, exponential
from fogbank.kinds.rays import slide
from fogbank.kinds.reduce import LOG_ZERO, split
from fogbank.model.fields import LayerBase, num


class Height(LayerBase):
    """Unreal/Filament height fog: rho * exp(-falloff * (y - base))."""
    model_config = ConfigDict(title="Height fog")
    kind: Literal["height"] = "height"
    source = "Exponential height fog, as in Unreal Engine and Filament"
    summary = "Fog that pools low and thins with height, like mist in a valley."
    formula = r"\rho(\mathbf{x}) = \rho_0\, e^{-k\,(y - h_0)}"
    density: float = num(0.03, 0, 10, 0.0005, "1/m", "extinction at the base height", title="density ρ₀")
    falloff: float = num(0.15, 0, 5, 0.005, "1/m", "how fast density drops with height", title="falloff k")
    base: float = num(0.0, -200, 200, 0.5, "m", "height where the density is ρ₀", title="base height h₀")


def density(layer, x, t, env):
    x = slide(layer, x, t, env.wind)
    return layer.density * np.exp(-layer.falloff * (x[:, 1] - layer.base))


def exprel_neg(x):
    """(1 - exp(-x)) / x, with its limit 1 at x = 0 (series below |x| < 1e-5)."""
    x = np.asarray(x, dtype=np.float64)
    small = np.abs(x) < 1e-5
    safe = np.where(small, 1.0, x)
    return np.where(small, 1.0 - x / 2.0 + x * x / 6.0, -np.expm1(-safe) / safe)


def optical_depth(layer, O, omega, d, t, env):
    """env.weight (the global density) multiplies the result inside the logarithm, where a
    tiny weight over a huge depth (e^3000 under the base) stays representable."""
    # tau = d rho(y_lo) (1 - exp(-k d |w_y|)) / (k d |w_y|), y_lo the segment's lower end:
    # one exponential of the height difference, exprel in (0, 1], taken as
    # exp(log rho - k (y_lo - h0) + log d + log exprel) so that no factor overflows alone
    O = slide(layer, O, t, env.wind)
    k = layer.falloff
    if layer.density <= 0 or env.weight <= 0:
        return np.zeros(len(d))
    y_lo = O[:, 1] + np.minimum(d * omega[:, 1], 0.0)
    with np.errstate(divide="ignore"):
        e = (np.log(layer.density) + np.log(env.weight) - k * (y_lo - layer.base) + np.log(d)
             + np.log(exprel_neg(k * d * np.abs(omega[:, 1]))))
    return np.where(d > 0, np.exp(np.minimum(e, 700.0)), 0.0)


def pack(layer, p):
    # the log-density at E's height, global density inside the log, as float32 hi + lo
    g = p.density
    log_rho = np.log(layer.density) + np.log(g) if layer.density > 0 and g > 0 else LOG_ZERO
    return {"log_density": split(log_rho - layer.falloff * (p.slid(layer)[1] - layer.base)),
            "falloff": layer.falloff}


def sample(rng):
    return Height(density=rng.uniform(0, 0.05), falloff=float(rng.choice([0.0, rng.uniform(0, 0.3)])),
                  base=rng.uniform(-10, 10), wind=bool(rng.random() < 0.5))


KIND = Kind(
    model=Height,
    layout=Layout("height", ("log_density", 2), ("falloff", 1)),
    pack=pack,
    code=exponential("heightOpticalDepth(Os, w, ds, {log_density}, {falloff})"),
    density_code=lambda r, v: r.format("rho += heightDensity(x, {log_density}, {falloff});"),
    sample=sample, optical_depth=optical_depth, density=density, seconds_per_mpx=0.03,
    cpu_only=frozenset({"wind"}),   # the wind is horizontal; the density depends on y alone
    loop=False,   # tiny code: inlined (kinds/kind.py Kind.loop)
)
