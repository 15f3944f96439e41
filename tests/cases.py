"""One accuracy case: a look drawn from the model, its rays, and the truth's parts for
them (tests/domain.py, tests/quadrature.py). Shared by tests/test_accuracy.py and
scripts/accuracy.py, so both measure the same draws."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from domain import draw_look, draw_rays
from fogbank.kinds.noise_bake import bake
from fogbank.model.params import FogParams
from fogbank.kinds.particle_motion import simulate
from fogbank.scene.terrain import flat
from quadrature import raw


@dataclass
class Case:
    fog: FogParams
    O: np.ndarray
    W: np.ndarray
    D: np.ndarray
    tex: np.ndarray
    states: dict
    parts: list      # quadrature.raw per ray (None: out of the truth's reach)


def tune_density(fog, parts, rng):
    """Most looks get the global density (a field like any other, in [0, 20]) that brings
    the median ray's optical depth near 1, so that the rays land where T is neither 0 nor 1
    and an error can show; the rest keep the density they were drawn with."""
    taus = [max(math.exp(min(p[0], 700.0)) + p[2], 0.0) - p[1] for p in parts if p is not None]
    taus = [x for x in taus if math.isfinite(x) and x > 0]
    if not taus or rng.random() < 0.25:
        return fog
    return fog.model_copy(update={"density": float(np.clip(
        math.exp(rng.uniform(-1, 1)) / np.median(taus), 0.0, 20.0))})


def draw_case(kind: str, rng, scale: str, rays: int) -> Case:
    fog = draw_look(kind, rng, scale)
    t = fog.time
    tex = bake(fog.noise.size, fog.noise.octaves, fog.noise.blur, fog.noise.seed)
    states = {i: simulate(l, t, fog.wind.vector(), flat, ages=True) for i, l in enumerate(fog.layers)
              if l.kind == "particles"}
    extra = [p for pos, *_ in states.values() for p in pos[:8]]
    O, W, D = draw_rays(fog, rng, rays, scale, extra)
    parts = [raw(fog, O[i], W[i], D[i], t, tex, states) for i in range(rays)]
    return Case(tune_density(fog, parts, rng), O, W, D, tex, states, parts)
