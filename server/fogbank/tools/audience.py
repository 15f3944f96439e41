"""Viewers of one live session (issue 34): a presenter that shares its session and N
viewers of its live link, every frame acknowledged as it arrives (as the page does), over
loopback. Measures each viewer's frames against the presenter's, the renders the worker
made (the server's own count, /metrics) against the presenter's frames, and the server's
CPU: its web process (which sends every viewer's frames) and its render workers.
`fogbank bench-live` writes docs/bench-live.md."""

from __future__ import annotations

import asyncio
import json
import os
import secrets
import struct
import time
import urllib.request

import websockets

from fogbank.tools.link import run_in_thread
from fogbank.workers import proctree

TICK = os.sysconf("SC_CLK_TCK")


def cpu_s(pid: int) -> float:
    """CPU seconds (user and system) that process `pid` has used."""
    try:
        with open(f"/proc/{pid}/stat") as fh:
            fields = fh.read().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / TICK


def renders(url: str) -> float:
    """Frames the server's workers rendered, by its own count (fogbank_render_ms_count)."""
    with urllib.request.urlopen(url + "/metrics", timeout=10) as r:
        for line in r.read().decode().splitlines():
            if line.startswith("fogbank_render_ms_count"):
                return float(line.split()[-1])
    return 0.0


async def _reader(ws, counts: list, key: int, t0: float, t1: float) -> None:
    """Acknowledge every frame; count those that arrive between t0 and t1."""
    while True:
        left = t1 - time.monotonic()
        if left <= 0:
            return
        try:
            m = await asyncio.wait_for(ws.recv(), left)
        except (asyncio.TimeoutError, websockets.ConnectionClosed):
            return
        if isinstance(m, bytes):
            await ws.send(json.dumps({"type": "ack", "frame": struct.unpack_from("<I", m, 4)[0]}))
            if time.monotonic() >= t0:
                counts[key] += 1
        else:
            msg = json.loads(m)
            if msg.get("type") == "ping":
                await ws.send(json.dumps({"type": "pong", "ping": msg["ping"]}))


async def audience(url: str, viewers: int, seconds: float = 6.0, size=(640, 360), settle_s: float = 2.0,
                   codecs=("vp09", "jpeg"), query: str = "v=1", pid: int | None = None) -> dict:
    """One presenter and `viewers` viewers for `seconds` (after `settle_s`): frames a
    second of the presenter and of each viewer, renders a presenter frame, and (with the
    server's `pid`) its CPU in cores: the web process and its render workers."""
    ws_url = url.replace("http", "ws", 1) + "/ws?"
    room = secrets.token_urlsafe(16)
    view = {"type": "view", "width": size[0], "height": size[1], "fps": 30, "codecs": list(codecs)}
    # (max_queue None: a client that stops reading at the end must still see its close
    # handshake through the messages that came meanwhile; with 16, the last viewers' closes
    # each waited out their 10 s timeout)
    async with websockets.connect(ws_url + f"{query}&room={room}", max_size=2**24, max_queue=None) as p:
        await p.recv(), await p.recv()
        await p.send(json.dumps(view))
        await p.send(json.dumps({"type": "share"}))
        token = None
        while token is None:   # the live link's token, from the audience message
            m = await asyncio.wait_for(p.recv(), 30)
            if isinstance(m, bytes):
                await p.send(json.dumps({"type": "ack", "frame": struct.unpack_from("<I", m, 4)[0]}))
            elif json.loads(m).get("type") == "audience":
                token = json.loads(m)["token"]
        socks = []
        try:
            for _ in range(viewers):
                v = await websockets.connect(ws_url + f"live={token}", max_size=2**24, max_queue=None)
                socks.append(v)
                await v.send(json.dumps(view))
            counts = [0] * (viewers + 1)
            t0 = time.monotonic() + settle_s
            t1 = t0 + seconds
            readers = [asyncio.ensure_future(_reader(ws, counts, i, t0, t1)) for i, ws in enumerate([p, *socks])]
            await asyncio.sleep(max(0.0, t0 - time.monotonic()))
            r0 = renders(url)
            workers = proctree.descendants(pid) if pid else []
            c0 = (cpu_s(pid), sum(cpu_s(w) for w in workers)) if pid else (0.0, 0.0)
            me0 = time.process_time()
            await asyncio.gather(*readers)
            me1 = time.process_time()
            c1 = (cpu_s(pid), sum(cpu_s(w) for w in workers)) if pid else (0.0, 0.0)
            r1 = renders(url)
        finally:
            await asyncio.gather(*(v.close() for v in socks))
    fps = [c / seconds for c in counts]
    return {"viewers": viewers, "presenter_fps": round(fps[0], 2),
            "viewer_fps_min": round(min(fps[1:]), 2) if viewers else None,
            "viewer_fps_mean": round(sum(fps[1:]) / viewers, 2) if viewers else None,
            "renders_a_frame": round((r1 - r0) / max(1, counts[0]), 3),
            "web_cores": round((c1[0] - c0[0]) / seconds, 3), "worker_cores": round((c1[1] - c0[1]) / seconds, 3),
            "client_cores": round((me1 - me0) / seconds, 3)}


async def separate(url: str, sessions: int, seconds: float = 6.0, size=(640, 360), settle_s: float = 2.0,
                   codecs=("vp09", "jpeg"), query: str = "v=1") -> dict:
    """What watching cost before live sessions: `sessions` sessions of the same look, each
    its own render and encode; frames a second, the least and the mean."""
    ws_url = url.replace("http", "ws", 1) + "/ws?" + query
    view = {"type": "view", "width": size[0], "height": size[1], "fps": 30, "codecs": list(codecs)}
    socks = []
    try:
        for _ in range(sessions):
            ws = await websockets.connect(ws_url, max_size=2**24, max_queue=None)
            socks.append(ws)
            await ws.recv(), await ws.recv()
            await ws.send(json.dumps(view))
        counts = [0] * sessions
        t0 = time.monotonic() + settle_s
        await asyncio.gather(*(_reader(ws, counts, i, t0, t0 + seconds) for i, ws in enumerate(socks)))
    finally:
        await asyncio.gather(*(ws.close() for ws in socks))
    fps = [c / seconds for c in counts]
    return {"sessions": sessions, "fps_min": round(min(fps), 2), "fps_mean": round(sum(fps) / sessions, 2)}


def _rss(pid: int) -> int:
    """Resident bytes of process `pid`."""
    return proctree.rss_bytes(pid)


def _viewers_gauge(url: str) -> float:
    with urllib.request.urlopen(url + "/metrics", timeout=10) as r:
        for line in r.read().decode().splitlines():
            if line.startswith("fogbank_live_viewers "):
                return float(line.split()[-1])
    return -1.0


async def churn(url: str, seconds: float = 20.0, pid: int | None = None, most: int = 12, seed: int = 1,
                size=(320, 180)) -> dict:
    """A presenter plays a shared look (VP9, acknowledging every frame) while viewers join
    and leave its live link for `seconds`, at most `most` at once, each one of: "good"
    (acknowledges, stays 0.2-2 s, closes), "mute" (never acknowledges, stays 1-3 s),
    "abrupt" (acknowledges, then its TCP connection is cut, no close), "flipper" (flips its
    codecs every 50 ms, stays 1-2 s). Returns the presenter's frames a second alone (2 s)
    and during the churn, how many viewers came and of which kind, the frames they got,
    what the presenter was last told of its viewers and the server's viewer gauge once
    they are gone, and (with the server's `pid`) the web process's resident MB before the
    churn (after 5 viewers came and went) and after."""
    import random
    rnd = random.Random(seed)
    ws_url = url.replace("http", "ws", 1) + "/ws?"
    room = secrets.token_urlsafe(16)
    view = {"type": "view", "width": size[0], "height": size[1], "fps": 30, "codecs": ["vp09", "jpeg"]}
    frames = {"presenter": [], "viewers": 0}
    told = {"viewers": None}
    async with websockets.connect(ws_url + f"v=1&time=3&room={room}", max_size=2**24, max_queue=None) as p:
        await p.recv(), await p.recv()
        await p.send(json.dumps(view))
        await p.send(json.dumps({"type": "share"}))
        token = asyncio.get_running_loop().create_future()

        async def present():
            try:
                while True:
                    m = await p.recv()
                    if isinstance(m, bytes):
                        frames["presenter"].append(time.monotonic())
                        await p.send(json.dumps({"type": "ack", "frame": struct.unpack_from("<I", m, 4)[0]}))
                    else:
                        msg = json.loads(m)
                        if msg.get("type") == "audience":
                            told["viewers"] = msg["viewers"]
                            if msg["token"] and not token.done():
                                token.set_result(msg["token"])
            except websockets.ConnectionClosed:
                return
        presenting = asyncio.ensure_future(present())
        tok = await asyncio.wait_for(token, 30)
        live = ws_url + f"live={tok}&room={tok.split('.')[0]}"

        async def viewer(kind: str, stay: float):
            try:
                v = await websockets.connect(live, max_size=2**24, max_queue=None)
            except (OSError, websockets.InvalidHandshake):
                return
            try:
                await v.send(json.dumps(view))
                end = time.monotonic() + stay
                flip = 0
                while (left := end - time.monotonic()) > 0:
                    try:
                        m = await asyncio.wait_for(v.recv(), min(left, 0.05))
                    except asyncio.TimeoutError:
                        m = None
                    if isinstance(m, bytes):
                        frames["viewers"] += 1
                        if kind != "mute":
                            await v.send(json.dumps({"type": "ack", "frame": struct.unpack_from("<I", m, 4)[0]}))
                    if kind == "flipper":
                        flip += 1
                        await v.send(json.dumps({**view, "codecs": ["vp09", "jpeg"] if flip % 2 else ["jpeg"]}))
                if kind == "abrupt":
                    v.transport.abort()
                else:
                    await v.close()
            except websockets.ConnectionClosed:
                pass

        await asyncio.sleep(2.0)   # the look's programs, the presenter alone
        await asyncio.gather(*(viewer("good", 0.5) for _ in range(5)))
        await asyncio.sleep(1.0)
        rss0 = _rss(pid) if pid else 0
        t0 = time.monotonic()
        alone = [t for t in frames["presenter"] if t0 - 2.0 <= t < t0]
        kinds = {"good": 0, "mute": 0, "abrupt": 0, "flipper": 0}
        running: set = set()
        while time.monotonic() - t0 < seconds:
            running = {t for t in running if not t.done()}
            if len(running) < most:
                kind = rnd.choice(["good", "good", "mute", "abrupt", "flipper"])
                kinds[kind] += 1
                stay = {"good": rnd.uniform(0.2, 2.0), "mute": rnd.uniform(1.0, 3.0),
                        "abrupt": rnd.uniform(0.2, 2.0), "flipper": rnd.uniform(1.0, 2.0)}[kind]
                running.add(asyncio.ensure_future(viewer(kind, stay)))
            await asyncio.sleep(rnd.uniform(0.02, 0.2))
        t1 = time.monotonic()
        await asyncio.gather(*running)
        during = [t for t in frames["presenter"] if t0 <= t < t1]
        deadline = time.monotonic() + 15.0   # the abrupt ones: their sockets found dead
        while time.monotonic() < deadline and (told["viewers"] != 0 or _viewers_gauge(url) != 0):
            await asyncio.sleep(0.25)
        rss1 = _rss(pid) if pid else 0
        presenting.cancel()
    return {"presenter_fps_alone": round(len(alone) / 2.0, 2), "presenter_fps": round(len(during) / (t1 - t0), 2),
            "viewers": kinds, "viewer_frames": frames["viewers"], "told_viewers": told["viewers"],
            "viewers_gauge": _viewers_gauge(url), "web_rss_mb": (round(rss0 / 2**20, 1), round(rss1 / 2**20, 1))}


def bench(viewers=(0, 1, 5, 10, 20), seconds: float = 8.0, out: str | None = None) -> list[dict]:
    """`audience` with each number of viewers, on one server of this code (one worker)."""
    from fogbank.tools.child import ChildServer
    srv = ChildServer(env={"FOGBANK_WORKERS": "1"})
    rows = []
    try:
        run_in_thread(audience(srv.url, 0, 2.0, settle_s=2.0))   # warm: the look's programs compiled
        for n in viewers:
            r = run_in_thread(audience(srv.url, n, seconds, pid=srv.proc.pid))
            print(f"  {n:3d} viewers: {r}", flush=True)
            rows.append(r)
        apart = run_in_thread(separate(srv.url, viewers[-1] + 1, seconds))
        print(f"  {apart}", flush=True)
    finally:
        srv.stop()
    if out:
        base = rows[0]
        lines = ["# fogbank benchmark: viewers of one live session (issue 34)", "",
                 f"`fogbank bench-live --seconds {seconds:g}` on {os.cpu_count()} cores, one render worker. A presenter "
                 "streams the default look with time running at 640x360 (VP9, as the page asks) and shares it; N "
                 "viewers open its live link. Every client acknowledges each frame as it arrives and runs in the "
                 "benchmark's own process, on the same machine. Renders a frame: the server's count of renders "
                 "(/metrics) over the presenter's frames. CPU: cores used by the web process (it sends every "
                 "viewer's frames) and by the render workers; the clients' (this benchmark's process, which shares "
                 "the 2 cores) beside them.", "",
                 "| viewers | presenter fps | viewer fps, min / mean | least viewer / presenter | renders a presenter frame "
                 "| web process, cores | render workers, cores | the clients, cores |", "|---|---|---|---|---|---|---|---|"]
        for r in rows:
            ratio = f"{r['viewer_fps_min'] / r['presenter_fps']:.2f}" if r["viewers"] and r["presenter_fps"] else "-"
            vf = f"{r['viewer_fps_min']} / {r['viewer_fps_mean']}" if r["viewers"] else "-"
            lines.append(f"| {r['viewers']} | {r['presenter_fps']} | {vf} | {ratio} | {r['renders_a_frame']} | "
                         f"{r['web_cores']} | {r['worker_cores']} | {r['client_cores']} |")
        last = rows[-1]
        if last["viewers"]:
            per = (last["web_cores"] - base["web_cores"]) / last["viewers"]
            per_frame = per / max(0.01, last["presenter_fps"]) * 1000
            lines += ["", f"Web-process CPU per added viewer: {per * 100:.2f}% of a core "
                          f"({per_frame:.2f} ms a presenter frame), from {base['viewers']} to {last['viewers']} "
                          "viewers."]
        lines += ["", f"Before live sessions, each watcher had a session of its own: {apart['sessions']} sessions of the "
                      f"same look on the same worker got {apart['fps_min']} to {apart['fps_mean']} frames a second "
                      "(least, mean), each frame its own render and encode."]
        with open(out, "w") as fh:
            fh.write("\n".join(lines) + "\n")
    return rows
