"""Control-to-frame latency of a slider dragged over the benchmark's 16-layer looks at
960x540 (tools/bench.py COSTLY, the issue 13 target: p95 at most 250 ms), each look in
turn on one server, the way `fogbank bench` measures it, and each look given twice in the
command line measured twice (its second run finds the worker's programs compiled). Starts
its own server on 127.0.0.1 (stopped by PID), with the code on PYTHONPATH:

    .venv/bin/python scripts/drag_latency.py "16, every kind" "16 x cosine" "16, every kind"
    PYTHONPATH=<checkout of another commit>/server .venv/bin/python scripts/drag_latency.py ...

With no look named, every look of the benchmark.
"""

from __future__ import annotations

import asyncio
import sys

from fogbank.tools.bench import costly_looks
from fogbank.tools.bench_stream import drag_latency
from fogbank.tools.child import ChildServer


def main(names: list[str]) -> None:
    looks = costly_looks()
    srv = ChildServer()
    try:
        url = srv.url.replace("http", "ws", 1)
        for name in names or list(looks):
            r = asyncio.run(drag_latency(url, looks[name], 960, 540))
            print(f"{name:18s} p50 {r['p50_ms']:5.0f} p95 {r['p95_ms']:5.0f} max {r['max_ms']:5.0f} ms, "
                  f"previews {r['preview_width']:4.0f} px wide, render {r['render_ms']:4.0f} ms", flush=True)
    finally:
        srv.stop()


if __name__ == "__main__":
    main(sys.argv[1:])
