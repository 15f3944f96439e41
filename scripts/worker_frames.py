"""Stream frames as a render worker makes them, in this process made a worker
(workers/worker.py init: its own GL context, malloc settings and warm-up): the default look
at 1280x720 with the camera still and time running (MSAA, the held fog), then 448x252
previews of an orbiting camera (a drag's previews). For each: ms a frame, the worker's
render and encode ms (medians), and page faults a frame (the readback and the heap's top:
docs/design.md, "Render workers"). tests/gl/test_output.py runs it with --json.

    .venv/bin/python scripts/worker_frames.py [--frames N] [--json]
    PYTHONPATH=<checkout of another commit>/server .venv/bin/python scripts/worker_frames.py

scripts/gpu_profile.sh runs it on a GPU machine.
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import time


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--json", action="store_true", help="one line of JSON: page faults a frame by stream")
    a = ap.parse_args()
    from fogbank.model.params import StillParams
    from fogbank.model.presets import preset_dict
    from fogbank.workers import worker
    worker.init("auto", None, 0, 512 << 20, 0)
    look = StillParams.model_validate({**preset_dict("default"), "width": 1280, "height": 720})
    small = look.model_copy(update={"width": 448, "height": 252})

    def still(i: int) -> dict:
        return worker.frame(look.model_copy(update={"time": 2.0 + i / 30}), "still", True, 80, hold_fog=True)

    def orbit(i: int) -> dict:
        cam = look.camera.model_copy(update={"yaw": look.camera.yaw + 0.3 * i})
        return worker.frame(small.model_copy(update={"time": 2.0 + i / 30, "camera": cam}), "orbit", False, 60,
                            draft=True)
    out = {}
    for name, frame in (("still 1280x720", still), ("orbit 448x252", orbit)):
        # The warm-up draws the very frames measured: with Mesa's shader cache cold (a clean
        # machine: CI) llvmpipe builds a variant at some frame of the orbit (at 10-20, one took
        # 100 ms and 101 page faults), a one-off that is no per-frame cost.
        for i in range(a.frames):
            frame(10 + i)
        faults0, t0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt, time.perf_counter()
        res = [frame(10 + i) for i in range(a.frames)]
        ms = (time.perf_counter() - t0) * 1000 / a.frames
        faults = (resource.getrusage(resource.RUSAGE_SELF).ru_minflt - faults0) / a.frames
        out[name] = faults
        if not a.json:
            print(f"{name}: {ms:.1f} ms a frame, render {statistics.median(r['render_ms'] for r in res):.1f}, "
                  f"encode {statistics.median(r['encode_ms'] for r in res):.1f}, page faults a frame {faults:.0f}")
    if a.json:
        print(json.dumps(out))


if __name__ == "__main__":
    main()
