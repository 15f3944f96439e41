import os, time
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
from fogbank.model import presets as P
from fogbank.model.params import StillParams
from fogbank.workers import cost
from fogbank.render.renderer import Renderer, create_context
W, H = 960, 540
def look(size, samples, eff, n=1):
    return {"width": W, "height": H, "noise": {"size": size, "octaves": 6 if size == 128 else 4},
            "layers": [{"kind": "noise", "mode": "volume", "samples": samples}] * n, "effects": eff}
off = {"sun_through_fog": False, "shafts": 0.0, "lit": False, "blur": "off"}
variants = [("t64 s128", look(64, 128, off)), ("t128 s128", look(128, 128, off)), ("t128 s32", look(128, 32, off)),
            ("t128 s128 sun", look(128, 128, {**off, "sun_through_fog": True})),
            ("t128 s128 lit", look(128, 128, {**off, "lit": True})),
            ("t128 s128 shafts", look(128, 128, {**off, "shafts": 1.0})),
            ("t128 s128 lit+shafts", look(128, 128, {**off, "lit": True, "shafts": 1.0})),
            ("t128 s128 blur", look(128, 128, {**off, "blur": "separate", "blur_radius": 12})),
            ("no layers", {"width": W, "height": H, "layers": [], "effects": off}),
            ]
r = Renderer(create_context("egl"))
for name, lk in variants:
    s = P.patched(lk, {**P.preset_dict("default"), "width": 1280, "height": 720}, StillParams)
    c = cost.estimate(s, fmt="png", compiled=True, baked=True)
    r.render(s)
    ts = []
    for k in range(2):
        t0 = time.perf_counter(); r.render(s.model_copy(update={"time": s.time + 1 + k})); ts.append(time.perf_counter() - t0)
    print(f"{name:22s} est {c.seconds:6.2f} s  measured {min(ts):6.2f} s  ratio {min(ts) / c.seconds:4.2f}", flush=True)
