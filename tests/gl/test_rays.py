"""The GLSL path against the float64 reference, through POST /api/transmittance.

For every layer kind: random layers and rays (degenerate ones included), max |dT| <= 2e-4.
The printed table is the "max GLSL-vs-reference error" per kind.
"""

from __future__ import annotations

import numpy as np
import pytest

from draws import ALL, random_layer, random_rays
from fogbank.kinds.reference import transmittance as reference
from fogbank.model.params import FogParams

TOL = 2e-4


def glsl(client, fog: FogParams, O, W, D, t):
    body = {"params": fog.model_dump(mode="json"),
            "rays": [{"origin": list(o), "direction": list(w), "length": float(d), "time": t}
                     for o, w, d in zip(O, W, D)]}
    r = client.post("/api/transmittance", json=body)
    assert r.status_code == 200, r.text
    return np.array(r.json()["transmittance"])


@pytest.mark.parametrize("kind", ALL)
def test_glsl_matches_reference(client, kind):
    rng = np.random.default_rng(1000 + ALL.index(kind))
    worst = 0.0
    for _ in range(12):
        layer = random_layer(kind, rng)
        t = float(rng.uniform(0, 20))
        fog = FogParams(layers=[layer], wind={"direction": float(rng.uniform(0, 360)),
                                              "speed": float(rng.uniform(0, 5))})
        O, W, D = random_rays(rng, 64)
        got = glsl(client, fog, O, W, D, t)
        want = reference(fog, O, W, D, t)
        err = np.abs(got - want)
        worst = max(worst, float(err.max()))
        assert err.max() <= TOL, (layer, int(err.argmax()), got[err.argmax()], want[err.argmax()])
    print(f"\n{kind:12s} max |T_glsl - T_ref| = {worst:.2e}")


def test_all_layers_with_effects(client):
    """Every kind at once, with start/cutoff distances, max opacity and global density."""
    rng = np.random.default_rng(7)
    for _ in range(6):
        layers = [random_layer(k, rng) for k in ALL]
        fog = FogParams(layers=layers, density=float(rng.uniform(0, 3)),
                        effects={"start_distance": float(rng.uniform(0, 20)),
                                 "cutoff_distance": float(rng.choice([0.0, rng.uniform(50, 150)])),
                                 "max_opacity": float(rng.uniform(0.3, 1)),
                                 "cutoff_mode": str(rng.choice(["clear", "fog"]))})
        O, W, D = random_rays(rng, 128)
        t = float(rng.uniform(0, 10))
        got = glsl(client, fog, O, W, D, t)
        want = reference(fog, O, W, D, t)
        assert np.abs(got - want).max() <= TOL


def test_rays_at_different_times(client):
    """Rays carry their own time: wind slides sensitive layers, particles fly."""
    fog = FogParams(layers=[{"kind": "sphere", "center": (0, 0, 0), "radius": 10, "density": 0.2,
                             "wind": True}], wind={"direction": 90, "speed": 4})
    O = np.array([[-30.0, 0.0, 0.0]] * 3)
    W = np.array([[1.0, 0.0, 0.0]] * 3)
    D = np.array([60.0] * 3)
    times = [0.0, 5.0, 100.0]
    body = {"params": fog.model_dump(mode="json"),
            "rays": [{"origin": list(o), "direction": list(w), "length": d, "time": t}
                     for o, w, d, t in zip(O, W, D, times)]}
    T = np.array(client.post("/api/transmittance", json=body).json()["transmittance"])
    want = np.array([reference(fog, O[i:i + 1], W[i:i + 1], D[i:i + 1], times[i])[0] for i in range(3)])
    assert np.abs(T - want).max() <= TOL
    assert T[0] == pytest.approx(np.exp(-0.2 * 10 * 4 / 3), abs=TOL)   # through the centre
    assert T[2] == pytest.approx(1.0, abs=1e-6)                         # slid 400 m away
