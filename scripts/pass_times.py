"""Median milliseconds of each frame pass for presets at 1280x720 (MSAA, a new yaw each
frame so the scene pass is drawn too), with the GL finished after every pass. W, H and
FOG_SCALE set the size and fog scale (a 720p drag's preview: W=448 H=252 FOG_SCALE=4 MSAA=0).

    .venv/bin/python scripts/pass_times.py default fischer-smoke
    PYTHONPATH=/path/to/other/checkout/server .venv/bin/python scripts/pass_times.py default
"""

from __future__ import annotations

import sys
import time

import numpy as np
import os

MSAA = os.environ.get("MSAA", "1") == "1"
W, H = int(os.environ.get("W", "1280")), int(os.environ.get("H", "720"))
FOG_SCALE = os.environ.get("FOG_SCALE")


def main(names: list[str], frames: int = int(os.environ.get("FRAMES", "6"))) -> None:
    from fogbank.model.params import StillParams
    from fogbank.model.presets import preset_dict
    from fogbank.render.passes import FRAME_PASSES
    from fogbank.render.renderer import Renderer, create_context
    r = Renderer(create_context("egl"))
    for name in names:
        d = {**preset_dict(name), "width": W, "height": H}
        if FOG_SCALE:
            d["effects"] = {**d.get("effects", {}), "fog_scale": int(FOG_SCALE)}
        s = StillParams.model_validate(d)
        r.render(s)   # warm: programs, meshes, targets
        times: dict[str, list[float]] = {}
        for i in range(frames):
            cam = s.camera.model_copy(update={"yaw": s.camera.yaw + 1e-3 * (i + 1)})
            f = r.begin(s.model_copy(update={"camera": cam}), "still", MSAA)
            for p in FRAME_PASSES:
                t0 = time.perf_counter()
                p.run(r, f)
                r.ctx.finish()
                times.setdefault(p.name, []).append((time.perf_counter() - t0) * 1000.0)
        med = {k: float(np.median(v)) for k, v in times.items()}
        print(f"{name:16s} total {sum(med.values()):6.1f} ms  " +
              "  ".join(f"{k} {v:.1f}" for k, v in med.items() if v >= 0.5))


if __name__ == "__main__":
    main(sys.argv[1:] or ["default"])
