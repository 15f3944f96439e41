"""Homogeneous fog (OpenGL GL_EXP): rho constant, tau = rho d."""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import ConfigDict

from fogbank.kinds.kind import Kind, Layout, exponential
from fogbank.model.fields import LayerBase, num


class Homogeneous(LayerBase):
    """OpenGL's exponential fog: constant density."""
    model_config = ConfigDict(title="Homogeneous fog")
    kind: Literal["homogeneous"] = "homogeneous"
    source = "OpenGL fixed-function fog, GL_EXP"
    summary = "The same density everywhere: the view thins evenly with distance."
    formula = r"T = e^{-\rho d}"
    density: float = num(0.01, 0, 10, 0.0005, "1/m", "extinction coefficient", title="density ρ")


def density(layer, x, t, env):
    return np.full(len(x), layer.density)


def optical_depth(layer, O, omega, d, t, env):
    return env.weight * layer.density * d


KIND = Kind(
    model=Homogeneous,
    layout=Layout("homogeneous", ("density", 1)),
    pack=lambda layer, p: {"density": p.density * layer.density},
    code=exponential("homogeneousOpticalDepth({density}, ds)"),
    density_code=lambda r, v: r.format("rho += homogeneousDensity({density});"),
    sample=lambda rng: Homogeneous(density=rng.uniform(0, 0.05), wind=bool(rng.random() < 0.5)),
    optical_depth=optical_depth, density=density, seconds_per_mpx=0.03,
    cpu_only=frozenset({"wind"}),   # a constant density is the same slid by any wind
    loop=False,   # tiny code: inlined (kinds/kind.py Kind.loop)
)
