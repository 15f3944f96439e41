"""The stream as a remote viewer meets it (issue 34): a client that does what the page does
while orbiting (a camera message each animation frame, 60 a second, every frame
acknowledged on arrival) through a thin link (tools/relay.py), and what it measured: frames
a second, control-to-frame latency, and the bytes of text and of frames a second."""

from __future__ import annotations

import asyncio
import json
import struct
import time

import websockets

from fogbank.tools.relay import Relay


def sixteen_layer_query() -> str:
    """Issue 34's costly state: 16 cosine layers of 8 terms each (its `state` was 20.6 KB)."""
    from fogbank.model import presets as P
    from fogbank.model.params import FogParams
    from fogbank.model.urlstate import encode
    terms = [{"amp": 0.1, "k": [0.01 * (i + 1), 0.02, 0.013 * (i + 2)], "phase": 0.3 * i} for i in range(8)]
    layers = [{"kind": "cosine", "density": 0.0004, "c0": 1.0, "terms": terms} for _ in range(16)]
    look = FogParams.model_validate({**P.preset_dict("default"), "layers": layers})
    return encode(look)


async def orbit(url: str, query: str, seconds: float, size=(640, 360), hz: float = 60.0,
                step_deg: float = 0.5, settle_s: float = 2.0) -> dict:
    """Open /ws?query at `size`, wait `settle_s` for the look, then orbit for `seconds`: a
    camera message (yaw + step_deg) every 1/hz s inside an interaction, each frame acked as it
    arrives. Latency is the page's: a frame's arrival less the send time of the camera message
    its params version includes (each accepted camera message is one version)."""
    ws_url = url.replace("http", "ws", 1) + "/ws?" + query
    async with websockets.connect(ws_url, max_size=2**24) as ws:
        hello = json.loads(await ws.recv())
        state = json.loads(await ws.recv())
        await ws.send(json.dumps({"type": "view", "width": size[0], "height": size[1], "fps": 30}))
        yaw = state["params"]["camera"].get("yaw", 0.0)
        version0 = state["version"]
        sent: dict[int, float] = {}
        frames: list[tuple[float, int]] = []   # (arrival, bytes)
        texts: list[tuple[float, int]] = []
        lags: list[float] = []
        errors: list[str] = []
        orbiting = False
        t_start = time.monotonic()

        async def reader():
            while True:
                m = await ws.recv()
                now = time.monotonic()
                if isinstance(m, bytes):
                    frame, version = struct.unpack_from("<II", m, 4)
                    await ws.send(json.dumps({"type": "ack", "frame": frame}))
                    if orbiting:
                        frames.append((now, len(m)))
                        if version in sent:
                            lags.append(now - sent[version])
                else:
                    if orbiting:
                        texts.append((now, len(m.encode())))
                    msg = json.loads(m)
                    if msg.get("type") == "ping":   # as the page does: at once
                        await ws.send(json.dumps({"type": "pong", "ping": msg["ping"]}))
                    if msg.get("type") == "error":
                        errors.append(msg.get("msg", ""))

        task = asyncio.create_task(reader())
        try:
            await asyncio.sleep(settle_s)
            orbiting = True
            await ws.send(json.dumps({"type": "interact", "active": True}))
            t0 = time.monotonic()
            i = 0
            while time.monotonic() - t0 < seconds:
                i += 1
                yaw = (yaw + step_deg) % 360.0
                sent[version0 + i] = time.monotonic()
                await ws.send(json.dumps({"type": "camera", "camera": {"yaw": round(yaw, 3)}}))
                await asyncio.sleep(max(0.0, t0 + i / hz - time.monotonic()))
            t1 = time.monotonic()
            await ws.send(json.dumps({"type": "interact", "active": False}))
        finally:
            task.cancel()
            with _quiet():
                await task
    span = t1 - t0
    in_span = [b for t, b in frames if t <= t1]
    lags_sorted = sorted(lags)

    def pct(p):
        return lags_sorted[min(len(lags_sorted) - 1, int(p * len(lags_sorted)))] * 1000 if lags_sorted else None
    half = [lag for (t, _), lag in zip(frames, lags) if t > t0 + span / 2]
    return {"seconds": round(span, 2), "fps": round(len(in_span) / span, 2),
            "lag_p50_ms": pct(0.5), "lag_p95_ms": pct(0.95),
            "lag_p95_second_half_ms": (sorted(half)[int(0.95 * (len(half) - 1))] * 1000) if half else None,
            "text_mbps": round(sum(b for t, b in texts if t <= t1) * 8 / span / 1e6, 3),
            "frame_mbps": round(sum(in_span) * 8 / span / 1e6, 3),
            "texts": len(texts), "frames": len(in_span), "messages": i,
            "renderer": hello.get("renderer"), "errors": errors[:3], "started": t_start}


async def watch(url: str, query: str, seconds: float, size=(1280, 720), settle_s: float = 3.0,
                codecs: tuple[str, ...] = ("jpeg",)) -> dict:
    """Open /ws?query at `size` with time running and watch for `seconds` after `settle_s`:
    every frame acked as it arrives. Returns frames a second, Mbit/s of frames, and the
    frames' median JPEG quality and width (the rate controller's choices), and the last
    "link" estimate the server sent."""
    ws_url = url.replace("http", "ws", 1) + "/ws?" + query
    async with websockets.connect(ws_url, max_size=2**24) as ws:
        await ws.recv(), await ws.recv()
        # JPEG alone is the default, and said only otherwise: a server before video frames
        # refuses a view that names codecs (and its frames would keep their first size)
        view = {"type": "view", "width": size[0], "height": size[1], "fps": 30}
        if tuple(codecs) != ("jpeg",):
            view["codecs"] = list(codecs)
        await ws.send(json.dumps(view))
        frames: list[tuple[float, int, int, int]] = []   # (arrival, bytes, quality, width)
        encode_ms: list[float] = []
        link: dict = {}
        t0 = time.monotonic() + settle_s
        t1 = t0 + seconds
        while time.monotonic() < t1:
            try:
                m = await asyncio.wait_for(ws.recv(), max(0.05, t1 - time.monotonic()))
            except asyncio.TimeoutError:
                break
            now = time.monotonic()
            if isinstance(m, bytes):
                frame = struct.unpack_from("<I", m, 4)[0]
                width, _, quality = struct.unpack_from("<HHB", m, 28)
                encode_ms.append(struct.unpack_from("<f", m, 24)[0])
                await ws.send(json.dumps({"type": "ack", "frame": frame}))
                if now >= t0:
                    frames.append((now, len(m), quality, width))
            else:
                msg = json.loads(m)
                if msg.get("type") == "ping":   # as the page does: at once
                    await ws.send(json.dumps({"type": "pong", "ping": msg["ping"]}))
                if msg.get("type") == "link":
                    link = msg
    span = seconds
    q = sorted(f[2] for f in frames)
    w = sorted(f[3] for f in frames)
    return {"fps": round(len(frames) / span, 2), "frame_mbps": round(sum(f[1] for f in frames) * 8 / span / 1e6, 3),
            "kb": round(sum(f[1] for f in frames) / max(1, len(frames)) / 1024, 1),
            "quality": q[len(q) // 2] if q else None, "width": w[len(w) // 2] if w else None, "link": link,
            "encode_ms": round(sorted(encode_ms)[len(encode_ms) // 2], 1) if encode_ms else None}


def watch_through(server_url: str, query: str, rate_bps: float | None, rtt_ms: float, seconds: float,
                  size=(1280, 720), codecs: tuple[str, ...] = ("jpeg",)) -> dict:
    """`watch` through a Relay to the server at `server_url` (rate None and no delay: loopback)."""
    if rate_bps is None and not rtt_ms:
        return run_in_thread(watch(server_url, query, seconds, size, codecs=codecs))
    port = int(server_url.rsplit(":", 1)[1])
    with Relay(port, rate_bps, rtt_ms) as relay:
        return run_in_thread(watch(relay.url, query, seconds, size, codecs=codecs))


def run_in_thread(coro):
    """asyncio.run in a thread of its own: a caller may have a loop running in its thread
    already (Playwright's sync API leaves one in a test process)."""
    import threading
    out: dict = {}

    def target():
        try:
            out["value"] = asyncio.run(coro)
        except BaseException as exc:  # noqa: BLE001 - raised again in the caller's thread
            out["error"] = exc
    t = threading.Thread(target=target)
    t.start()
    t.join()
    if "error" in out:
        raise out["error"]
    return out["value"]


class _quiet:
    def __enter__(self):
        return self

    def __exit__(self, kind, exc, tb):
        return kind is not None and issubclass(kind, (asyncio.CancelledError, websockets.ConnectionClosed))


def orbit_through(server_url: str, query: str, rate_bps: float | None, rtt_ms: float, seconds: float,
                  size=(640, 360)) -> dict:
    """`orbit` through a Relay to the server at `server_url` (rate None: loopback, no relay)."""
    if rate_bps is None and not rtt_ms:
        return run_in_thread(orbit(server_url, query, seconds, size))
    port = int(server_url.rsplit(":", 1)[1])
    with Relay(port, rate_bps, rtt_ms) as relay:
        return run_in_thread(orbit(relay.url, query, seconds, size))


def summary(rows: list[dict]) -> str:
    return "\n".join(f"{r['label']:34s} {r['fps']:6.2f} fps  lag p50 {r['lag_p50_ms'] or 0:7.0f} ms  "
                     f"p95 {r['lag_p95_ms'] or 0:7.0f} ms  text {r['text_mbps']:6.3f} Mbit/s  "
                     f"frames {r['frame_mbps']:6.3f} Mbit/s" for r in rows)


async def frames_vs_stills(url: str, codec: str, seconds: float = 6.0, size=(1280, 720), samples: int = 6) -> dict:
    """The default look playing at `size`, streamed as `codec` ("jpeg" or "vp09") for
    `seconds`: its Mbit/s, and the mean SSIM (tools/codecs.py) of the last `samples` full
    frames to the stills of their own times (GET /api/still.png)."""
    import io
    import urllib.request

    import av
    import numpy as np
    from PIL import Image

    from fogbank.tools.codecs import ssim
    ws_url = url.replace("http", "ws", 1) + "/ws?v=1&time=3"
    got = []   # (time, RGB array, bytes)
    total, t0 = 0, None
    dec = av.CodecContext.create("vp9", "r")
    async with websockets.connect(ws_url, max_size=2**24) as ws:
        await ws.recv(), await ws.recv()
        await ws.send(json.dumps({"type": "view", "width": size[0], "height": size[1], "fps": 30,
                                  "codecs": [codec, "jpeg"] if codec != "jpeg" else ["jpeg"]}))
        while t0 is None or time.monotonic() - t0 < seconds:
            m = await ws.recv()
            if isinstance(m, str):
                msg = json.loads(m)
                if msg.get("type") == "ping":
                    await ws.send(json.dumps({"type": "pong", "ping": msg["ping"]}))
                continue
            frame = struct.unpack_from("<I", m, 4)[0]
            t = struct.unpack_from("<d", m, 12)[0]
            await ws.send(json.dumps({"type": "ack", "frame": frame}))
            t0 = t0 or time.monotonic()
            total += len(m)
            if m[35] == 2:
                for d in dec.decode(av.Packet(m[36:])):
                    got.append((t, d.to_ndarray(format="rgb24")))
            elif m[33] & 1:
                got.append((t, np.asarray(Image.open(io.BytesIO(m[36:])).convert("RGB"))))
    scores = []
    for t, img in got[-samples:]:
        q = f"v=1&width={size[0]}&height={size[1]}&time={t!r}"
        with urllib.request.urlopen(f"{url}/api/still.png?{q}") as r:
            scores.append(ssim(img, np.asarray(Image.open(io.BytesIO(r.read())).convert("RGB"))))
    return {"mbps": total * 8 / seconds / 1e6, "ssim": float(np.mean(scores)), "fps": len(got) / seconds}


# (label, query maker, mode, rate bits/s or None, round trip ms): issue 34's links
LINK_CASES = (
    ("orbit default, loopback", "default", "orbit", None, 0),
    ("orbit default, 5 Mbit/s 40 ms", "default", "orbit", 5e6, 40),
    ("orbit default, 1 Mbit/s 40 ms", "default", "orbit", 1e6, 40),
    ("orbit default, 20 Mbit/s 80 ms", "default", "orbit", 20e6, 80),
    ("orbit 16 layers, loopback", "16", "orbit", None, 0),
    ("orbit 16 layers, 5 Mbit/s 40 ms", "16", "orbit", 5e6, 40),
    ("orbit 16 layers, 1 Mbit/s 40 ms", "16", "orbit", 1e6, 40),
    ("720p playing, loopback", "default", "watch", None, 0),
    ("720p playing, 5 Mbit/s 40 ms", "default", "watch", 5e6, 40),
    ("720p playing, 20 Mbit/s 80 ms", "default", "watch", 20e6, 80),
    ("720p playing, 2 Mbit/s 40 ms", "default", "watch", 2e6, 40),
    ("720p playing, 1 Mbit/s 40 ms", "default", "watch", 1e6, 40),
)


def bench(before_tree: str | None = None, seconds: float = 8.0, out: str | None = None) -> dict:
    """Each of LINK_CASES against a server of this code and, with `before_tree` (another
    checkout's `server` folder), one of that code, in turn, through the same relay and
    client (this code's). Writes a markdown table to `out` if given; returns the rows."""
    import os

    from fogbank.tools.bench import _tree_env
    from fogbank.tools.child import ChildServer
    trees = [("now", None)] + ([("before", before_tree)] if before_tree else [])
    q16 = sixteen_layer_query()
    rows: dict[str, dict[str, dict]] = {}
    for name, tree in trees:
        srv = ChildServer(env=_tree_env(tree) if tree else {})
        try:
            for label, look, mode, rate, rtt in LINK_CASES:
                query = q16 if look == "16" else "v=1"
                if mode == "orbit":
                    r = orbit_through(srv.url, query, rate, rtt, seconds, size=(1280, 720))
                else:
                    r = watch_through(srv.url, query, rate, rtt, seconds)
                rows.setdefault(label, {})[name] = r
                print(f"  {name:6s} {label:34s} {r['fps']:6.2f} fps", flush=True)
        finally:
            srv.stop()
    quality: dict[str, dict] = {}
    srv = ChildServer()
    try:   # this code only: the frames' fidelity, JPEG q80 and VP9, on loopback
        for codec in ("jpeg", "vp09"):
            quality[codec] = run_in_thread(frames_vs_stills(srv.url, codec, seconds))
            print(f"  now    720p playing {codec:5s} {quality[codec]}", flush=True)
        for label, rate in (("720p playing VP9, 5 Mbit/s 40 ms", 5e6), ("720p playing VP9, 1 Mbit/s 40 ms", 1e6)):
            rows.setdefault(label, {})["now"] = watch_through(srv.url, "v=1", rate, 40, seconds, codecs=("vp09", "jpeg"))
    finally:
        srv.stop()
    if out:
        lines = ["# fogbank benchmark: the stream through a thin link (issue 34)", "",
                 f"`fogbank bench-link{' --before-tree ' + before_tree if before_tree else ''} "
                 f"--seconds {seconds:g}` on {os.cpu_count()} cores. A client acks every frame and answers "
                 "pings as the page does; the relay (tools/relay.py) delays each direction by half the round "
                 "trip and paces the server's bytes. Orbit: a camera message every 1/60 s inside an "
                 "interaction, the view 1280x720 (the previews' sizes are the ladder's); lag is the page's "
                 "control-to-frame latency. Playing: the default look with time running at 1280x720.", "",
                 "| case | code | fps | lag p50 / p95 ms | text Mbit/s | frames Mbit/s | frame KB, quality, width |",
                 "|---|---|---|---|---|---|---|"]
        for label, by in rows.items():
            for name, r in by.items():
                lag = (f"{r['lag_p50_ms']:.0f} / {r['lag_p95_ms']:.0f}" if r.get("lag_p95_ms") is not None else "-")
                shape = (f"{r['kb']} KB, q{r['quality']}, {r['width']} px" if "kb" in r else "-")
                lines.append(f"| {label} | {name} | {r['fps']:.1f} | {lag} | {r.get('text_mbps', '-')} | "
                             f"{r['frame_mbps']} | {shape} |")
        lines += ["", "The default look playing at 1280x720 on loopback, this code: the stream's bits a second and "
                  "the mean SSIM (luma, 7x7) of its last full frames to the stills of their own times.", "",
                  "| frames | Mbit/s | fps | SSIM to the stills |", "|---|---|---|---|"]
        lines += [f"| {'JPEG q80' if c == 'jpeg' else 'VP9'} | {q['mbps']:.2f} | {q['fps']:.1f} | {q['ssim']:.4f} |"
                  for c, q in quality.items()]
        with open(out, "w") as fh:
            fh.write("\n".join(lines) + "\n")
    return rows
