"""The ray under the cursor (model/ray_plot.py) on the calibration scene against hand
references: the ray from the documented camera convention (tests/hand.py), its ground
hit from the plane's equation, the densities written out by hand, and T(s) in closed
form for constant and height fog."""

from __future__ import annotations

import numpy as np
import pytest

from fogbank.model.params import FogParams
from fogbank.model.ray_plot import plot_ray
from hand import hand_rays

pytestmark = pytest.mark.unit


def look(**kw):
    return FogParams.model_validate({
        "scene": "calibration", "time": 0.0, "effects": {"sky_distance": 400.0},
        "camera": {"position": (3.0, 6.0, 2.0), "yaw": 10.0, "pitch": -8.0, "fov": 60.0}, **kw})


def test_the_ray_its_ground_hit_densities_and_t():
    rho, k, h0, rho0 = 0.01, 0.2, 1.0, 0.05
    f = look(layers=[{"kind": "homogeneous", "density": rho},
                     {"kind": "height", "density": rho0, "falloff": k, "base": h0}])
    x, y, W, H = 200.0, 150.0, 320, 180
    got = plot_ray(f, x, y, W, H)
    w = hand_rays(f.camera, [x], [H - 1 - y], W, H)[0]
    assert np.allclose(got["direction"], w, atol=1e-12)
    eye = np.array(f.camera.position)
    assert got["hit"] == "ground"
    assert abs(got["distance"] - (-eye[1] / w[1])) <= 1e-3          # marched, then bisected
    s = np.array(got["s"])
    p = eye + s[:, None] * w
    assert np.allclose(got["layers"][0]["density"], rho)
    assert np.allclose(got["layers"][1]["density"], rho0 * np.exp(-k * (p[:, 1] - h0)), rtol=1e-12)
    # T(s) = exp(-rho s - rho0 e^{-k (y0 - h0)} (1 - e^{-k w_y s}) / (k w_y)): by hand
    tau = rho * s + rho0 * np.exp(-k * (eye[1] - h0)) * (1 - np.exp(-k * w[1] * s)) / (k * w[1])
    assert np.allclose(got["T"], np.exp(-tau), rtol=1e-9)


def test_the_sky_runs_to_the_sky_distance_and_direct_kinds_give_their_t():
    f = look(camera={"position": (0.0, 5.0, 0.0), "yaw": 0.0, "pitch": 20.0, "fov": 40.0},
             effects={"sky_distance": 9000.0},
             layers=[{"kind": "distance", "start": 0.0, "distance": 300.0, "exponent": 1.0, "low": 1.0,
                      "high": 1.0, "max": 0.8}])
    got = plot_ray(f, 100.0, 20.0, 200, 100)
    assert got["hit"] == "sky" and got["distance"] == 9000.0   # as far as the frame's sky ray
    (layer,) = got["layers"]
    assert "density" not in layer
    s = np.array(got["s"])
    # Gawron's F = clamp(N (d / D)^e, 0, max) with N = 1 everywhere: T = 1 - F
    assert np.allclose(layer["transmittance"], 1 - np.clip(s / 300.0, 0, 0.8), atol=1e-9)
