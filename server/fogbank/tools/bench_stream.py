"""Streaming measurements with a real WebSocket client against a running server:
frames per second delivered, and the latency from a control change to the first frame
that shows it. Used by `fogbank bench-stream`.
"""

from __future__ import annotations

import asyncio
import json
import statistics
import time

import websockets

from fogbank.stream.protocol import HEADER


async def _session(url: str, query: str, width: int, height: int, fps: int):
    ws = await websockets.connect(f"{url}/ws?{query}", max_size=None)
    await ws.recv()   # hello
    await ws.recv()   # state
    await ws.send(json.dumps({"type": "view", "width": width, "height": height, "fps": fps,
                              "quality": 80}))
    return ws


async def _frames(ws, seconds: float, on_frame=None, on_text=None) -> list[tuple]:
    out = []
    end = time.monotonic() + seconds
    while True:
        left = end - time.monotonic()
        if left <= 0:
            return out
        try:
            m = await asyncio.wait_for(ws.recv(), left)
        except asyncio.TimeoutError:
            return out
        if isinstance(m, bytes):
            h = HEADER.unpack(m[:HEADER.size])
            out.append((time.monotonic(), h, len(m)))
            await ws.send(json.dumps({"type": "ack", "frame": h[1]}))
            if on_frame:
                await on_frame(h)
        elif on_text:
            await on_text(json.loads(m))


async def delivered_fps(url: str, query: str, width: int, height: int, seconds: float = 8.0,
                        orbit: bool = False, fps_cap: int = 120, drag: bool = False) -> dict:
    """Frames per second a client receives (after 2 s of warm-up), and the server's
    render and encode times from the frame headers. With `drag`, the client says it is
    interacting first, as the page does while the camera is dragged (previews)."""
    ws = await _session(url, query, width, height, fps_cap)
    try:
        await _frames(ws, 2.0)
        if drag:
            await ws.send(json.dumps({"type": "interact", "active": True}))
        yaw = [0.0]
        if orbit:   # a first move, so that a paused look has a frame to answer
            await ws.send(json.dumps({"type": "camera", "camera": {"yaw": yaw[0]}}))

        async def move(_h):
            if orbit:
                yaw[0] += 2.0
                await ws.send(json.dumps({"type": "camera", "camera": {"yaw": yaw[0]}}))
        frames = await _frames(ws, seconds, on_frame=move)
    finally:
        await ws.close()
    if len(frames) < 2:
        return {"fps": 0.0, "frames": len(frames)}
    span = frames[-1][0] - frames[0][0]
    return {"fps": (len(frames) - 1) / span, "frames": len(frames),
            "width": statistics.median(f[1][6] for f in frames),
            "render_ms": statistics.median(f[1][4] for f in frames),
            "encode_ms": statistics.median(f[1][5] for f in frames),
            "kb": statistics.median(f[2] for f in frames) / 1024}


async def control_latency(url: str, query: str, width: int, height: int, changes: int = 30) -> dict:
    """Time from sending a params change to the first frame whose params version shows
    it, over `changes` changes spaced 300 ms apart, while time runs."""
    ws = await _session(url, query, width, height, 120)
    lat: list[float] = []
    try:
        await _frames(ws, 1.5)
        for i in range(changes):
            sent = time.monotonic()
            await ws.send(json.dumps({"type": "params", "params": {"density": 1.0 + (i % 2) * 0.5}}))
            version = [None]

            async def on_text(t):
                if t.get("type") == "state":
                    version[0] = t["version"]
            done = asyncio.Event()

            async def on_frame(h):
                if version[0] is not None and h[2] >= version[0] and not done.is_set():
                    lat.append((time.monotonic() - sent) * 1000)
                    done.set()
            end = time.monotonic() + 5
            while not done.is_set() and time.monotonic() < end:
                await _frames(ws, 0.05, on_frame=on_frame, on_text=on_text)
            await _frames(ws, 0.3)
    finally:
        await ws.close()
    lat.sort()
    pick = lambda q: lat[min(len(lat) - 1, int(q * len(lat)))]  # noqa: E731
    return {"p50_ms": pick(0.5), "p95_ms": pick(0.95), "p99_ms": pick(0.99), "n": len(lat)}


def run(url: str, query: str = "v=1") -> list[dict]:
    rows = []
    for w, h in ((640, 360), (1280, 720)):
        for orbit in (False, True):
            r = asyncio.run(delivered_fps(url, query, w, h, orbit=orbit))
            rows.append({"size": f"{w}x{h}", "camera": "orbit" if orbit else "still", **r})
            print(f"{w}x{h} {'orbit' if orbit else 'still':5s}  {r['fps']:6.1f} fps delivered  "
                  f"render {r.get('render_ms', 0):6.1f} ms  encode {r.get('encode_ms', 0):5.1f} ms  "
                  f"{r.get('kb', 0):5.0f} KB")
        lat = asyncio.run(control_latency(url, query, w, h))
        rows.append({"size": f"{w}x{h}", "latency": lat})
        print(f"{w}x{h} control-to-frame latency  p50 {lat['p50_ms']:.0f} ms  p95 {lat['p95_ms']:.0f} ms  "
              f"p99 {lat['p99_ms']:.0f} ms  (n={lat['n']})")
    return rows


def density_change(i: int) -> dict:
    """The i-th change of a dragged density slider."""
    return {"density": 1.0 + 0.02 * (i % 5)}


def sun_change(i: int) -> dict:
    """The i-th change of a dragged sun azimuth slider (2 degrees a change)."""
    return {"sun": {"azimuth": 30.0 + 2.0 * i}}


async def drag_latency(url: str, look: dict, width: int, height: int, changes: int = 24,
                       every_s: float = 0.15, settle_s: float = 30.0, change=density_change) -> dict:
    """A slider dragged over a costly look, as the page does it. The look is set and its
    frames awaited: the first (first_ms: a new fog program compiles on its first draw) and
    the refined one after input stops (refined_ms), `settle_s` at most, as a user looks at
    a look before changing it. Then `interact` on and a change (`change(i)`, a params
    patch: the global density by default) every `every_s` while time runs. The latency of
    each change is the time to the first frame whose params version shows it (a later
    change's frame counts for it too: the page shows the newest look). Also the previews'
    median width and the frames' render ms."""
    from fogbank.stream.protocol import FLAG_FULL
    ws = await _session(url, "v=1", width, height, 120)
    lat: list[float] = []
    widths: list[int] = []
    render: list[float] = []
    first_ms = refined_ms = None
    try:
        sent = time.monotonic()
        await ws.send(json.dumps({"type": "params", "params": look, "replace": True}))
        version = [None]

        async def on_text(t):
            if t.get("type") == "state":
                version[0] = t["version"]
        refined = asyncio.Event()

        async def settle(h):
            nonlocal first_ms, refined_ms
            if version[0] is not None and h[2] >= version[0]:
                if first_ms is None:
                    first_ms = (time.monotonic() - sent) * 1000
                if h[9] & FLAG_FULL:
                    refined_ms = (time.monotonic() - sent) * 1000
                    refined.set()
        end = time.monotonic() + settle_s
        while not refined.is_set() and time.monotonic() < end:
            await _frames(ws, 0.1, on_frame=settle, on_text=on_text)
        await ws.send(json.dumps({"type": "interact", "active": True}))
        pending: list[tuple[int | None, float]] = []   # (version, sent)

        async def on_state(t):
            if t.get("type") == "state":
                for i, (v, s) in enumerate(pending):
                    if v is None:
                        pending[i] = (t["version"], s)
                        break

        async def on_frame(h):
            widths.append(h[6])
            render.append(h[4])
            while pending and pending[0][0] is not None and h[2] >= pending[0][0]:
                lat.append((time.monotonic() - pending.pop(0)[1]) * 1000)
        for i in range(changes):
            pending.append((None, time.monotonic()))
            await ws.send(json.dumps({"type": "params", "params": change(i)}))
            await _frames(ws, every_s, on_frame=on_frame, on_text=on_state)
        end = time.monotonic() + 10
        while pending and time.monotonic() < end:
            await _frames(ws, 0.05, on_frame=on_frame, on_text=on_state)
        lat += [(time.monotonic() - s) * 1000 for _, s in pending]   # never shown: as long as we waited
        await ws.send(json.dumps({"type": "interact", "active": False}))
    finally:
        await ws.close()
    lat.sort()
    pick = lambda q: lat[min(len(lat) - 1, int(q * len(lat)))]  # noqa: E731
    return {"p50_ms": pick(0.5), "p95_ms": pick(0.95), "max_ms": lat[-1], "n": len(lat),
            "preview_width": statistics.median(widths) if widths else 0,
            "render_ms": statistics.median(render) if render else 0.0,
            "first_ms": first_ms, "refined_ms": refined_ms}
