"""Fischer's particle layer (kinds/particles.py): a preview's thinned swarm."""

from __future__ import annotations

import numpy as np
import pytest

from fogbank.kinds.packing import pack_layers
from fogbank.kinds.particles import Particles
from fogbank.model.params import FogParams
from fogbank.render.frame import Simulations

pytestmark = pytest.mark.unit

LAYER = {"kind": "particles", "count": 64, "life_min": 40, "life_max": 80, "step": 0.1,
         "alpha": 0.3, "radius": 5.0, "seed": 11}


def test_a_thinned_swarm_is_every_kth_particle_of_the_layers_own():
    """A preview draws every k-th particle of the look's own swarm, k times as opaque (at
    most 1), so that changing a preview's detail simulates nothing again: the thinned
    layer's state is the full layer's cache entry, and its packed rows are that state's
    every k-th row, farthest from the reference point first (the quads composite their
    light back to front)."""
    fog = FogParams.model_validate({"layers": [LAYER]})
    sims = Simulations()
    t = 7.3
    pos, strength, age = sims.state(fog.layers[0], t, fog)
    assert len(pos) > 16
    for k in (1, 4, 16):
        thin = fog.layers[0].thinned(k)
        assert thin.model_dump_json() == fog.layers[0].model_dump_json()   # the URL's layer
        assert sims.state(thin, t, fog)[0] is pos                         # no new simulation
        look = fog.model_copy(update={"layers": [thin]})
        packed = pack_layers(look, {0: (pos, strength, age)}, ref=(1.0, 2.0, 3.0), time=t)
        v = packed.values[0]
        want, want_s = pos[::k], strength[::k]
        far = np.argsort(-np.linalg.norm(want - np.array([1.0, 2.0, 3.0]), axis=1), kind="stable")
        assert v["count"] == len(want) == -(-len(pos) // k)
        assert v["alpha"] == min(1.0, 0.3 * k)
        rows = packed.particles[v["first"]:v["first"] + v["count"]].astype(np.float64)
        np.testing.assert_allclose(rows[:, :3], want[far] - np.array([1.0, 2.0, 3.0]), atol=1e-4)
        np.testing.assert_allclose(rows[:, 3], want_s[far], atol=1e-6)
        dist = np.linalg.norm(rows[:, :3], axis=1)
        assert np.all(np.diff(dist) <= 1e-4)   # farthest first
        assert thin.drawn == -(-64 // k)


def test_thinning_is_not_a_field():
    """A layer read from a URL or a body draws every particle, and cannot ask for less."""
    from pydantic import ValidationError
    layer = Particles.model_validate(LAYER)
    assert layer.drawn == 64
    assert "_stride" not in layer.model_dump() and "_stride" not in Particles.model_json_schema()["properties"]
    with pytest.raises(ValidationError):
        Particles.model_validate({**LAYER, "_stride": 4})


def test_a_particle_grows_from_r_at_birth_to_growth_r_at_the_end_of_its_life():
    """Each packed row's radius is R (1 + (growth - 1) a), a the particle's age over its
    life: the state's ages agree with Fischer's strength (remaining life over life, faded
    in over the first steps: s <= 1 - a, equal once faded in), and the rows, sorted
    farthest first, carry their own particle's radius. growth 1 keeps every radius R."""
    fog = FogParams.model_validate({"layers": [{**LAYER, "growth": 3.0}]})
    t = 9.1
    pos, strength, age = Simulations().state(fog.layers[0], t, fog)
    assert np.all((age >= 0.0) & (age < 1.0))
    assert np.all(strength <= 1.0 - age + 1e-12)
    faded_in = np.isclose(strength, 1.0 - age, rtol=0, atol=1e-12)
    assert int(faded_in.sum()) >= 0.9 * len(age)
    assert float(age.min()) < 0.1 and float(age.max()) > 0.9   # young and old particles both
    ref = np.array([1.0, 2.0, 3.0])
    packed = pack_layers(fog, {0: (pos, strength, age)}, ref=tuple(ref), time=t)
    v = packed.values[0]
    far = np.argsort(-np.linalg.norm(pos - ref, axis=1), kind="stable")
    rows = slice(v["first"], v["first"] + v["count"])
    np.testing.assert_allclose(packed.radii[rows], 5.0 * (1.0 + 2.0 * age[far]), rtol=1e-6)
    flat = FogParams.model_validate({"layers": [LAYER]})
    packed = pack_layers(flat, {0: (pos, strength, age)}, ref=tuple(ref), time=t)
    assert np.all(packed.radii[rows] == np.float32(5.0))
