"""Control-to-frame latency of a slider dragged at 960x540 (issue 13: p95 at most 250 ms
for any valid look), over looks drawn from the whole domain the params model allows
(tests/domain.py draw_model: every field, up to 16 layers of any kinds, every effect),
each the way `fogbank bench` measures its hand-picked looks (tools/bench_stream.py
drag_latency). Starts its own server on 127.0.0.1 (stopped by PID):

    .venv/bin/python scripts/drag_domain.py 12 7      # 12 looks, seed 7

Prints one line per look (with the server's process tree RSS after it), the workers
recycled, and the looks whose p95 is over the target, as URL queries.
"""

from __future__ import annotations

import asyncio
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from domain import draw_model  # noqa: E402

from fogbank.model.params import FogParams  # noqa: E402
from fogbank.model.urlstate import encode  # noqa: E402
from fogbank.tools.bench_stream import drag_latency  # noqa: E402
from fogbank.tools.child import ChildServer  # noqa: E402

TARGET_MS = 250.0


def main(n: int, seed: int) -> int:
    rng = np.random.default_rng(seed)
    looks = [draw_model(FogParams, rng, "domain") for _ in range(n)]
    over = []
    srv = ChildServer()
    try:
        url = srv.url.replace("http", "ws", 1)
        for i, fog in enumerate(looks):
            kinds = ",".join(l.kind for l in fog.layers if l.enabled) or "-"
            r = asyncio.run(drag_latency(url, fog.model_dump(mode="json"), 960, 540))
            first = f"{r['first_ms']:.0f}" if r["first_ms"] is not None else "-"
            refined = f"{r['refined_ms']:.0f}" if r["refined_ms"] is not None else "never"
            print(f"{i:2d} p50 {r['p50_ms']:5.0f} p95 {r['p95_ms']:5.0f} max {r['max_ms']:5.0f} ms "
                  f"previews {r['preview_width']:4.0f} px render {r['render_ms']:5.0f} ms first {first} "
                  f"refined {refined} ms | fog_scale {fog.effects.fog_scale} blur {fog.effects.blur} "
                  f"RSS {srv.rss_mb():.0f} MB | scene {fog.scene} {kinds}", flush=True)
            if r["p95_ms"] > TARGET_MS:
                over.append((i, r["p95_ms"], encode(fog)))
        events = [line for line in srv.log_text().splitlines() if "recycled" in line or "Traceback" in line]
        print("\n".join(events) if events else "no worker was recycled")
    finally:
        srv.stop()
    for i, p95, query in over:
        print(f"look {i}: p95 {p95:.0f} ms > {TARGET_MS:.0f}: ?{query}")
    print(f"{n - len(over)} of {n} looks within {TARGET_MS:.0f} ms")
    return 1 if over else 0


if __name__ == "__main__":
    sys.exit(main(int(sys.argv[1]) if len(sys.argv) > 1 else 12, int(sys.argv[2]) if len(sys.argv) > 2 else 7))
