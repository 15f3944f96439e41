"""The ray under the cursor, in float64: each layer's density along it and the whole
fog's T(s) from the eye (POST /api/plot/ray; the page's plot panel draws it).

The ray goes through the centre of pixel (x, y) of a width x height view (y counted from
the top, as the page's pointer), as the frame's camera casts it (scene/camera.py). It
runs to the ground (marched in 1 m steps over the scene's height field, then bisected to
a millimetre; trees and buildings are not hit) or as far as the sky's fog runs
(sky_distance, as the frame's sky rays). Densities come from each kind's
float64 density (1/m, before the global density); a layer with none (particles, distance
fog, surface noise: their transmittance is not an integral of a density) gives its own
T_j(s) instead. T(s) is kinds/reference.transmittance over [0, s]: the global density,
start and cutoff distances and max opacity included, as a frame applies them.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from fogbank.kinds import KINDS
from fogbank.kinds.kind import Env
from fogbank.kinds.reference import layer_transmittance, noise_tex, simulated_states, transmittance
from fogbank.model.params import FogParams
from fogbank.model.suggest import ray_lengths
from fogbank.scene import camera as cam
from fogbank.scene import terrain

SAMPLES = 200


def _ground(look: FogParams, p: np.ndarray) -> float:
    return float(terrain.height(p[0], p[2])) if look.scene == "countryside" else 0.0


def _refine(look: FogParams, eye: np.ndarray, w: np.ndarray, d: float) -> float:
    """The ground hit within the 1 m march step that found it, by bisection (to 1 mm)."""
    lo, hi = max(0.0, d - 1.0), d
    for _ in range(12):
        mid = 0.5 * (lo + hi)
        p = eye + w * mid
        if p[1] < _ground(look, p):
            hi = mid
        else:
            lo = mid
    return hi


def plot_ray(look: FogParams, x: float, y: float, width: int, height: int,
             samples: int = SAMPLES) -> dict[str, Any]:
    eye = np.asarray(look.camera.position, dtype=np.float64)
    w = cam.view(look.camera, width, height).ray(np.array([x]), np.array([height - 1 - y]), width, height)
    d = float(ray_lengths(look, eye, w, step=1.0)[0])
    far = min(look.effects.sky_distance, 4000.0)
    hit = d < far
    if hit:
        d = _refine(look, eye, w[0], d)
    else:   # the sky's ray runs as far as the frame's does (sky_distance, uncapped)
        d = look.effects.sky_distance
    s = np.linspace(0.0, d, samples + 1)[1:]          # metres from the eye
    n = len(s)
    O = np.broadcast_to(eye, (n, 3))
    omega = np.broadcast_to(w[0], (n, 3))
    t = np.full(n, look.time)
    x_s = eye + omega * s[:, None]
    # every noise layer, drawn or not, is plotted: the tile if any of them samples it
    tex = noise_tex(look) if any(KINDS[l.kind].uses_noise for l in look.layers) else None
    env = Env(wind=look.wind.vector(), tex=tex)
    # each particle layer simulated once, for its own T and the whole fog's
    states = simulated_states(look, float(look.time))
    layers = []
    for i, layer in enumerate(look.layers):
        kind = KINDS[layer.kind]
        entry: dict[str, Any] = {"index": i, "kind": layer.kind, "enabled": layer.enabled}
        if kind.density is not None and not (layer.kind == "noise" and layer.mode != "volume"):
            entry["density"] = kind.density(layer, x_s, t, env).tolist()
        else:
            entry["transmittance"] = layer_transmittance(layer, look, O, omega, s, t, tex=tex,
                                                         state=states.get(i)).tolist()
        layers.append(entry)
    return {"s": s.tolist(), "distance": d, "hit": "ground" if hit else "sky",
            "direction": w[0].tolist(), "T": transmittance(look, O, omega, s, t, states=states).tolist(),
            "layers": layers}
