"""The scene pass's cost against the cost model's (workers/cost.py SCENE_*): each pass of
the default look over a scene at sizes from 160x90 to 1280x720, with and without MSAA,
the scene pass drawn (a fresh slot) and the GL finished after every pass (medians of 5),
and the model's scene part beside them:

    .venv/bin/python scripts/cost_fit.py countryside
"""

from __future__ import annotations

import statistics
import sys
import time

from fogbank.model.params import StillParams
from fogbank.model.presets import preset_dict
from fogbank.render.passes import FRAME_PASSES
from fogbank.render.renderer import Renderer, create_context
from fogbank.workers.cost import estimate

SCENE_PARTS = ("scene", "sky", "resolve")


def main(scene: str) -> None:
    r = Renderer(create_context())
    look = {**preset_dict("default"), "scene": scene}
    for w in (160, 240, 480, 960, 1280):
        h = w * 9 // 16
        for msaa in (False, True):
            s = StillParams.model_validate({**look, "width": w, "height": h})
            r.render(s, slot="warm", msaa=msaa)   # programs compiled, noise baked
            per: dict[str, list[float]] = {}
            for i in range(5):
                r.drop_slot("fit")
                f = r.begin(s.model_copy(update={"time": 1 + 0.1 * i}), "fit", msaa)
                for p in FRAME_PASSES:
                    r.ctx.finish()
                    t0 = time.perf_counter()
                    p.run(r, f)
                    r.ctx.finish()
                    per.setdefault(p.name, []).append((time.perf_counter() - t0) * 1000)
                r.keep_only(f)
            m = {k: statistics.median(v) for k, v in per.items()}
            model = estimate(s, msaa=msaa, compiled=True, baked=True).parts["width*height (scene pass)"] * 1000
            print(f"{scene} {w}x{h} msaa={int(msaa)}: scene+sky+resolve {sum(m[k] for k in SCENE_PARTS):6.1f} ms, "
                  f"model {model:6.1f} ms | " + " ".join(f"{k} {v:.1f}" for k, v in m.items() if v >= 0.1),
                  flush=True)
    r.drop_slot("fit")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "countryside")
