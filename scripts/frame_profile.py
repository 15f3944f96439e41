"""Where a 1280x720 stream frame of the default look goes, in this process: the camera
still with time running (MSAA, the scene pass and the fog that does not move held) and
orbiting (no MSAA, a new yaw each frame). For each: the render's median ms as a worker
calls it (Renderer.render), the same frame pass by pass with the GL finished after each
(tools/bench.py where_the_time_goes, the fog plan apart), and the Python functions that
take the most time of 20 renders (cProfile). Then two streams with light shafts and
different suns drawn in turn on one renderer, against one alone (each frame samples its
sun's shadow map: render/resources.py ShadowMaps).

    .venv/bin/python scripts/frame_profile.py
    PYTHONPATH=<checkout of another commit>/server .venv/bin/python scripts/frame_profile.py

docs/bench-gpu.md quotes its output on the H200.
"""

from __future__ import annotations

import cProfile
import io
import pstats
import statistics
import time


def main() -> None:
    from fogbank.model.params import StillParams
    from fogbank.model.presets import preset_dict
    from fogbank.render.renderer import Renderer, create_context
    from fogbank.tools.bench import where_the_time_goes
    r = Renderer(create_context())
    print(r.info())
    look = StillParams.model_validate({**preset_dict("default"), "width": 1280, "height": 720})

    def frame(i: int, orbit: bool) -> StillParams:
        s = look.model_copy(update={"time": 2.0 + i / 30})
        if orbit:
            s = s.model_copy(update={"camera": look.camera.model_copy(update={"yaw": look.camera.yaw + 0.3 * i})})
        return s

    for orbit in (False, True):
        name = "orbit" if orbit else "held"

        def render(i: int) -> None:
            r.render(frame(i, orbit), slot=name, msaa=not orbit, hold_fog=not orbit)
        for i in range(6):   # programs, targets, and the held fog (its third frame on)
            render(i)
        ms = []
        for i in range(20):
            r.ctx.finish()
            t0 = time.perf_counter()
            render(10 + i)
            ms.append((time.perf_counter() - t0) * 1000)
        parts = where_the_time_goes(r, orbit=orbit, n=15)
        print(f"{name}: render {statistics.median(ms):.2f} ms (min {min(ms):.2f}) | pass by pass: "
              + ", ".join(f"{k} {v:.2f}" for k, v in parts.items() if v > 0.02))
        prof = cProfile.Profile()
        prof.enable()
        for i in range(20):
            render(40 + i)
        r.ctx.finish()
        prof.disable()
        out = io.StringIO()
        pstats.Stats(prof, stream=out).sort_stats("tottime").print_stats(15)
        print(out.getvalue()[out.getvalue().find("ncalls"):])

    shafts = StillParams.model_validate({**preset_dict("default"), "width": 960, "height": 540,
                                        "effects": {**preset_dict("default")["effects"], "shafts": 0.5}})
    other = shafts.model_copy(update={"sun": shafts.sun.model_copy(update={"azimuth": shafts.sun.azimuth + 40})})
    for s in (shafts, other):
        for i in range(4):
            r.render(s.model_copy(update={"time": 1 + i / 30}), slot=str(id(s)), hold_fog=True)
    for mode in ("one sun", "two suns in turn"):
        ms = []
        for i in range(8):
            s = shafts if mode == "one sun" or i % 2 == 0 else other
            t0 = time.perf_counter()
            r.render(s.model_copy(update={"time": 2 + i / 30}), slot=str(id(s)), hold_fog=True)
            ms.append((time.perf_counter() - t0) * 1000)
        print(f"960x540 with light shafts, {mode}: {statistics.median(ms):.1f} ms a frame")


if __name__ == "__main__":
    main()
