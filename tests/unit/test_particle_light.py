"""Each particle's share of the sunlight (kinds/particle_light.py), against the rule written
out pair by pair: the fog's optical depth toward the sun, and the clarity of every other
live particle whose sphere the particle's ray toward the sun crosses."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fogbank.kinds.packing import pack_layers
from fogbank.kinds.particle_light import particle_light
from fogbank.kinds.reference import density_optical_depth
from fogbank.model.params import FogParams
from fogbank.model.presets import preset_dict
from fogbank.render.frame import Simulations

pytestmark = pytest.mark.unit


def _by_pairs(fog, packed, ref, time, L, far) -> dict[int, float]:
    """row -> light, a pair at a time in plain Python floats (closest point of the segment
    row -> row + far L to each other particle's centre)."""
    out = {}
    for v in (v for k, v in zip(packed.kinds, packed.values) if k == "particles"):
        rows = range(int(v["first"]), int(v["first"] + v["count"]))
        pts = {i: [float(x) + float(r) for x, r in zip(packed.particles[i][:3], ref)] for i in rows}
        strength = {i: float(packed.particles[i][3]) for i in rows}
        for i in rows:
            log_clear = 0.0
            for j in rows:
                if j == i or strength[j] <= 0:
                    continue
                rel = [pj - pi for pj, pi in zip(pts[j], pts[i])]
                u = min(max(sum(a * b for a, b in zip(rel, L)), 0.0), far)
                dist = math.dist(rel, [u * b for b in L])
                opacity = float(v["alpha"]) * strength[j] * min(max(1.0 - dist / float(packed.radii[j]), 0.0), 1.0)
                log_clear += math.log1p(-min(opacity, 1.0 - 1e-12))
            tau = float(density_optical_depth(fog, np.array([pts[i]]), np.array([L]), np.array([far]),
                                              np.array([time]))[0])
            out[i] = math.exp(-tau + max(fog.density, 0.0) * log_clear)
    return out


@pytest.mark.parametrize("sun_elevation", [8.0, 35.0, 80.0])
def test_each_particle_is_lit_through_the_fog_and_the_other_particles(sun_elevation):
    """The default look's smoke (about 130 live particles of 160) at t = 14 s, positions
    packed relative to a point 60 m off: every row within 1e-6 of the pairs' rule (float32
    out), and the rows without a particle at 1."""
    d = preset_dict("default")
    fog = FogParams.model_validate({**d, "sun": {**d["sun"], "elevation": sun_elevation}})
    sims = Simulations()
    t = 14.0
    states = {i: sims.state(layer, t, fog) for i, layer in enumerate(fog.layers) if layer.kind == "particles"}
    ref = (-15.0, 34.0, 95.0)
    packed = pack_layers(fog, states, ref, t)
    L = [float(x) for x in fog.sun.direction()]
    got = particle_light(fog, packed, ref, t, L, 400.0)
    want = _by_pairs(fog, packed, ref, t, L, 400.0)
    assert 100 <= len(want) <= 160
    rows = np.array(sorted(want))
    assert float(np.max(np.abs(got[rows] - np.array([want[i] for i in rows])))) < 1e-6
    shaded = np.array([want[i] for i in rows])
    assert float(shaded.min()) < 0.9 * float(shaded.max())   # the swarm does shade itself
    others = np.setdiff1d(np.arange(len(got)), rows)
    assert np.all(got[others] == 1.0)
