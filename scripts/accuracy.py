"""Measure /api/transmittance against an independent float64 truth across the schema.

For every layer kind: looks drawn from the params model over the whole domain and at
scene scale (tests/domain.py), rays drawn at random, along the axes and aimed at the
layers' features, each compared with tests/quadrature.py. Prints, per kind and scale, the
number of looks and rays and the max |dT|, with the worst ray; writes JSON with --json.

    python scripts/accuracy.py                       # an in-process app (this checkout)
    python scripts/accuracy.py --url http://127.0.0.1:8000 --looks 200
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "server")]

from cases import draw_case  # noqa: E402
from quadrature import check, compose, noise_bound  # noqa: E402

from fogbank.kinds import KINDS as REGISTRY  # noqa: E402

KINDS = list(REGISTRY)   # every registered kind


def glsl(post, fog, O, W, D, t):
    body = {"params": fog.model_dump(mode="json"),
            "rays": [{"origin": [float(x) for x in o], "direction": [float(x) for x in w],
                      "length": float(d), "time": float(t)} for o, w, d in zip(O, W, D)]}
    status, out = post(body)
    if status != 200:
        return None, f"{status}: {str(out)[:300]}"
    return np.array([np.nan if v is None else v for v in out["transmittance"]], dtype=np.float64), None


def measure(post, kind: str, scale: str, looks: int, rays: int, seed: int):
    rng = np.random.default_rng(seed)
    worst = {"err": 0.0}
    n_rays = skipped = refused = informative = backward = broken = 0
    errs = []
    broken_cases = []
    tight = []        # volume-noise rays whose stated bound is <= 1/255: their errors
    volume = 0
    for _ in range(looks):
        c = draw_case(kind, rng, scale, rays)
        fog, O, W, D, tex, states, parts, t = c.fog, c.O, c.W, c.D, c.tex, c.states, c.parts, c.fog.time
        got, why = glsl(post, fog, O, W, D, t)
        if got is None:
            refused += 1
            worst.setdefault("refusals", []).append(why)
            continue
        for i in range(len(D)):
            if parts[i] is None:
                skipped += 1
                continue
            want = compose(fog, D[i], parts[i])
            n_rays += 1
            informative += 1e-3 < want < 0.999
            tol = 2e-4 if scale == "scene" else 1 / 255
            err, kept, how = check(fog, O[i], W[i], D[i], t, got[i], tol, tex, states)
            errs.append(err)
            if any(l.kind == "noise" and l.mode == "volume" for l in fog.layers):
                volume += 1
                if noise_bound(fog, tex, W[i], D[i]) <= 1 / 255:
                    tight.append(err)
            backward += how == "backward"
            broken += not kept
            if not kept and len(broken_cases) < 5:
                broken_cases.append({"err": float(err), "got": float(got[i]), "want": float(want),
                                     "origin": O[i].tolist(), "direction": W[i].tolist(),
                                     "length": float(D[i]), "params": fog.model_dump(mode="json")})
            if err > worst["err"]:
                worst = {"err": float(err), "kept": kept, "how": how, "got": float(got[i]),
                         "want": float(want), "origin": O[i].tolist(), "direction": W[i].tolist(),
                         "length": float(D[i]), "params": fog.model_dump(mode="json")}
    errs = np.array(errs) if errs else np.zeros(1)
    return {"kind": kind, "scale": scale, "looks": looks, "rays": n_rays, "skipped": skipped,
            "refused": refused, "informative": informative, "backward": backward, "broken": broken, "max": float(errs.max()), "p99": float(np.quantile(errs, 0.99)),
            "over_1_255": int((errs > 1 / 255).sum()), "over_2e-4": int((errs > 2e-4).sum()),
            "volume_rays": volume, "volume_tight": len(tight),
            "volume_tight_max": float(max(tight, default=0.0)),
            "worst": worst, "broken_cases": broken_cases}


def in_process_post():
    from fastapi.testclient import TestClient
    from fogbank.service.api import create_app
    client = TestClient(create_app())
    client.__enter__()

    def post(body):
        r = client.post("/api/transmittance", json=body)
        return r.status_code, r.json()
    return post


def http_post(url: str):
    import httpx
    client = httpx.Client(base_url=url, timeout=120)

    def post(body):
        r = client.post("/api/transmittance", json=body)
        return r.status_code, (r.json() if r.headers.get("content-type", "").startswith("application/json") else r.text)
    return post


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--url", help="a running fogbank (default: an in-process app)")
    ap.add_argument("--looks", type=int, default=200)
    ap.add_argument("--rays", type=int, default=8)
    ap.add_argument("--kinds", default=",".join(KINDS))
    ap.add_argument("--scales", default="domain,scene")
    ap.add_argument("--seed", type=int, default=9)
    ap.add_argument("--json", help="write the results here")
    a = ap.parse_args()
    post = http_post(a.url) if a.url else in_process_post()
    out = []
    print(f"{'kind':12s} {'scale':7s} {'looks':>5s} {'rays':>5s} {'max |dT|':>10s} {'p99':>9s} "
          f"{'>1/255':>6s} {'>2e-4':>6s} {'skip':>5s} {'422':>4s} {'0<T<1':>6s} {'bkwd':>5s} {'broken':>6s}")
    for kind in a.kinds.split(","):
        for scale in a.scales.split(","):
            t0 = time.perf_counter()
            r = measure(post, kind, scale, a.looks, a.rays, a.seed + KINDS.index(kind) * 7 + len(scale))
            r["seconds"] = time.perf_counter() - t0
            out.append(r)
            print(f"{kind:12s} {scale:7s} {r['looks']:5d} {r['rays']:5d} {r['max']:10.2e} {r['p99']:9.2e} "
                  f"{r['over_1_255']:6d} {r['over_2e-4']:6d} {r['skipped']:5d} {r['refused']:4d} "
                  f"{r['informative']:6d} {r['backward']:5d} {r['broken']:6d}", flush=True)
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
