"""Delivered stream fps at 640x360 (still camera and orbiting) of an older checkout
against this one, alternating servers in one run (this machine is noisy: compare ratios
measured together). Usage, from the repo root:

    git worktree add /tmp/before 7e5bbdb
    .venv/bin/python scripts/compare_stream.py /tmp/before/server [rounds] [seconds]

Each server is started on 127.0.0.1 and stopped by its PID; the old one runs with
PYTHONPATH pointing at its `server/` folder."""

from __future__ import annotations

import asyncio
import statistics
import sys

from fogbank.tools.bench_stream import delivered_fps
from fogbank.tools.child import ChildServer


def start(pythonpath: str | None, env: dict) -> ChildServer:
    """A server on 127.0.0.1 from this checkout, or from `pythonpath` (an older one)."""
    return ChildServer(timeout=120, env={**env, **({"PYTHONPATH": pythonpath} if pythonpath else {})})


def main() -> None:
    old = sys.argv[1]
    rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    seconds = float(sys.argv[3]) if len(sys.argv) > 3 else 15.0
    configs = [("before", old, {}), ("after, 1 frame per worker", None, {"FOGBANK_FRAMES_PER_WORKER": "1"}),
               ("after, 2 frames per worker", None, {"FOGBANK_FRAMES_PER_WORKER": "2"})]
    res: dict = {}
    for rnd in range(rounds):
        for name, pp, env in configs:
            srv = start(pp, env)
            try:
                ws = srv.url.replace("http", "ws", 1)
                asyncio.run(delivered_fps(ws, "v=1", 640, 360, seconds=3))   # warm
                for orbit in (False, True):
                    r = asyncio.run(delivered_fps(ws, "v=1", 640, 360, seconds=seconds, orbit=orbit))
                    res.setdefault((name, orbit), []).append(r["fps"])
                    print(f"round {rnd} {name:28s} {'orbit' if orbit else 'still'} {r['fps']:6.1f} fps", flush=True)
            finally:
                srv.stop()
    for orbit in (False, True):
        base = statistics.median(res[("before", orbit)])
        for name, _, _ in configs:
            m = statistics.median(res[(name, orbit)])
            print(f"{'orbit' if orbit else 'still'} {name:28s} median {m:6.1f} fps  ({m / base:.2f}x before)")


if __name__ == "__main__":
    main()
