"""The hard cases issue 9 names, through /api/transmittance of a running server, against
the independent float64 truth (tests/quadrature.py): prints each case's truth, the
server's T and |dT|.

    python scripts/issue9_hard_cases.py --url http://127.0.0.1:8000
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import httpx
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "server")]

from fogbank.kinds.noise_bake import bake  # noqa: E402
from fogbank.model.params import FogParams  # noqa: E402
from fogbank.model.presets import preset_dict  # noqa: E402
from quadrature import truth  # noqa: E402


def cases():
    height = next(l for l in preset_dict("default")["layers"] if l["kind"] == "height")
    yield "height: default preset's layer, eye 450 m up, straight down", \
        {"layers": [height]}, [0, 450, 0], [0, -1, 0], 450.0
    yield "height: falloff 5, a ray from 83 m down to 66 m", \
        {"layers": [{"kind": "height", "density": 0.03, "falloff": 5.0, "base": 0.0}]}, [0, 83, 0], [0, -1, 0], 17.0
    for k in (100, 300, 1000):
        yield f"sphere: optical depth 1 through the centre, eye at {k} R (R = 1 m), through the centre", \
            {"layers": [{"kind": "sphere", "center": [0, 0, 0], "radius": 1.0, "density": 0.75}]}, [k, 0, 0], [-1, 0, 0], 2.0 * k
        yield "sphere: the same, missing the centre by R/2", \
            {"layers": [{"kind": "sphere", "center": [0, 0, 0], "radius": 1.0, "density": 0.75}]}, \
            [k, 0, 0], (np.array([0, 0.5, 0]) - [k, 0, 0]).tolist(), 2.0 * k
    c = np.array([10.0, 5.0, -20.0])
    eye = c + [150.0, 40.0, 125.0]
    for miss in (0.0, 0.005):
        aim = c + [0, miss, 0] - eye
        yield f"potential: sharp point (c 0.01, e 100) from 200 m, missing by {miss} m", \
            {"layers": [{"kind": "potential", "center": c.tolist(), "strength": 0.3, "c": 0.01, "e": 100.0}]}, \
            eye.tolist(), aim.tolist(), 2 * float(np.linalg.norm(aim))
    yield "global density 0.01 over homogeneous 0.1/m, 1000 m", \
        {"layers": [{"kind": "homogeneous", "density": 0.1}], "density": 0.01}, [0, 0, 0], [1, 0, 0], 1000.0
    for kind, layer in (("cosine", {"kind": "cosine", "density": 0.02, "c0": 1.0, "scale": 7.0, "wind": True,
                                    "terms": [{"amp": 0.9, "k": [1.3, 0.4, -2.1], "phase": 0.2}]}),
                        ("polynomial", {"kind": "polynomial", "density": 0.02, "wind": True,
                                        "coeffs": [1.0, 0.5, 0.8], "axis": [0.11, 0.03, -0.07], "half_width": 1.0}),
                        ("noise", {"kind": "noise", "mode": "surface", "density": 0.02, "scale": 13.0,
                                   "height_falloff": False, "wind": True})):
        yield f"late time: {kind} with wind 1.5 m/s at t = 3.7e5 s", \
            {"layers": [layer], "time": 3.7e5, "wind": {"direction": 33.0, "speed": 1.5}}, [12, 3, -40], [0.6, -0.1, 0.79], 60.0
    yield "volume noise (16 samples), 150 m ray", \
        {"layers": [{"kind": "noise", "mode": "volume", "density": 0.02, "scale": 60.0}]}, [0, 5, 0], [0.6, 0.1, 0.79], 150.0
    yield "origin beyond float32 range (3.5e38)", {"layers": [{"kind": "homogeneous", "density": 0.01}]}, \
        [3.5e38, 0, 0], [1, 0, 0], 10.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--url", required=True)
    a = ap.parse_args()
    client = httpx.Client(base_url=a.url, timeout=120)
    for name, patch, O, W, d in cases():
        fog = FogParams.model_validate({"scene": "calibration", **patch})
        W = (np.asarray(W, float) / np.linalg.norm(W)).tolist()
        tex = bake(fog.noise.size, fog.noise.octaves, fog.noise.blur, fog.noise.seed)
        want = truth(fog, np.asarray(O, float), np.asarray(W), d, fog.time, tex) if abs(O[0]) < 1e30 else 1.0
        r = client.post("/api/transmittance", json={"params": fog.model_dump(mode="json"), "rays": [
            {"origin": O, "direction": W, "length": d, "time": fog.time}]})
        if r.status_code != 200:
            print(f"{name}: truth {want:.6f}, HTTP {r.status_code} {r.json()['detail'][0]['loc']}")
            continue
        got = r.json()["transmittance"][0]
        err = abs(got - want) if got is not None else math.inf
        print(f"{name}: truth {want:.6f}, got {got}, |dT| {err:.2e}")


if __name__ == "__main__":
    main()
