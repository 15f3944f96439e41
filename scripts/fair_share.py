"""A stream's frame rate alone and beside a hostile session on the same worker (issue 33,
finding 1): the default look at 640x360, playing, acknowledging every frame, for
`seconds`; then the same while a second client plays a 16-layer volume-noise look at
1920x1080 (and, with --reseed, changes its noise seed every 6 s; with --difference, the
default look's "difference" teaching view at 1920x1080 instead). Prints frames per
second, the longest gap between frames, and how many gaps passed 1 s, and the cores each
process of the server used meanwhile (the web process, each worker). Starts its own
server on 127.0.0.1 (stopped by PID):

    .venv/bin/python scripts/fair_share.py [--seconds 20] [--reseed | --difference]
"""

from __future__ import annotations

import argparse
import os
import statistics
import asyncio
import json

from fogbank.model import presets as P
from fogbank.model.params import FogParams
from fogbank.model.urlstate import encode
from fogbank.tools.bench_stream import _frames, _session
from fogbank.tools.child import ChildServer
from fogbank.workers import proctree

TICK = os.sysconf("SC_CLK_TCK")


def cpu_seconds(root: int) -> dict[str, float]:
    """CPU seconds (user + system) of `root` and each descendant, by a readable name."""
    out = {}
    for pid in proctree.descendants(root):
        try:
            with open(f"/proc/{pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                cmd = f.read().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        name = "web" if pid == root else ("tracker" if "resource_tracker" in cmd else "worker")
        out[f"{name} {pid}"] = (int(fields[11]) + int(fields[12])) / TICK
    return out


def hostile_query() -> str:
    look = P.preset_dict("default")
    look["layers"] = [{"kind": "noise", "mode": "volume", "density": 0.3}] * 16
    return encode(FogParams.model_validate(look))


def gaps(frames) -> tuple[float, int]:
    times = [f[0] for f in frames]
    d = [b - a for a, b in zip(times, times[1:])]
    return (max(d) if d else float("inf")), sum(1 for x in d if x > 1.0)


async def watch(url: str, seconds: float) -> dict:
    ws = await _session(url, "v=1&time=3", 640, 360, 30)
    try:
        await ws.send(json.dumps({"type": "play", "playing": True}))
        await _frames(ws, 2.0)
        frames = await _frames(ws, seconds)
    finally:
        await ws.close()
    longest, over = gaps(frames)
    span = frames[-1][0] - frames[0][0] if len(frames) > 1 else 1.0
    return {"fps": round((len(frames) - 1) / span, 1), "longest_gap_s": round(longest, 2), "gaps_over_1s": over,
            "render_ms": round(statistics.median(f[1][4] for f in frames), 1) if frames else None}


async def hostile(url: str, seconds: float, reseed: bool, stop: asyncio.Event, difference: bool = False) -> dict:
    ws = await _session(url, "v=1&time=3" if difference else hostile_query(), 1920, 1080, 30)
    n = [0]
    try:
        if difference:
            await ws.send(json.dumps({"type": "view", "width": 1920, "height": 1080, "fps": 30,
                                      "show": "difference"}))
        await ws.send(json.dumps({"type": "play", "playing": True}))
        seed = 1
        while not stop.is_set():
            got = await _frames(ws, 6.0)
            n[0] += len(got)
            if reseed:
                seed += 1
                await ws.send(json.dumps({"type": "params", "params": {"noise": {"seed": seed}}}))
    finally:
        await ws.close()
    return {"frames": n[0]}


async def main(seconds: float, reseed: bool, difference: bool = False) -> None:
    srv = ChildServer()
    try:
        url = srv.url.replace("http", "ws", 1)
        alone = await watch(url, seconds)
        stop = asyncio.Event()
        h = asyncio.create_task(hostile(url, seconds, reseed, stop, difference))
        await asyncio.sleep(4.0)   # the hostile look's first frames (compile, bake)
        c0, t0 = cpu_seconds(srv.proc.pid), asyncio.get_running_loop().time()
        beside = await watch(url, seconds)
        c1, t1 = cpu_seconds(srv.proc.pid), asyncio.get_running_loop().time()
        beside["cores"] = {k: round((c1[k] - c0[k]) / (t1 - t0), 2) for k in c1 if k in c0}
        stop.set()
        hf = await h
        print(json.dumps({"alone": alone, "beside_hostile": beside, "hostile": hf,
                          "kept": round(beside["fps"] / alone["fps"], 2) if alone["fps"] else None}))
    finally:
        srv.stop()


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--reseed", action="store_true")
    ap.add_argument("--difference", action="store_true")
    a = ap.parse_args()
    asyncio.run(main(a.seconds, a.reseed, a.difference))
