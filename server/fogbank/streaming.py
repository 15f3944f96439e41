"""Live frames over a WebSocket: the scheduler that shares the one render thread among
sessions, and the /ws endpoint.

The scheduler starts a frame for the next due session in round-robin order, with at most
`max_jobs` frames on the render thread (one: a second queued frame would only add a
frame of latency, since encoding already overlaps the next render). Each frame is a snapshot of its session (latest wins); it
is rendered, JPEG-encoded in a thread pool (overlapping the next render) and sent as
header + JPEG. A session never has more than MAX_IN_FLIGHT frames unacknowledged, so a
slow client gets fewer frames, never older ones.
"""

from __future__ import annotations

import asyncio
import logging
import time
import uuid
from collections import OrderedDict
from typing import Any

from starlette.websockets import WebSocket, WebSocketDisconnect, WebSocketState

from . import metrics
from .encode import encode
from .protocol import (FLAG_FULL, FLAG_PLAYING, MAX_MESSAGE, PROTOCOL, ProtocolError, QueryMsg,
                       frame_header, parse)
from .session import FrameJob, Session

log = logging.getLogger("fogbank.stream")


class Client:
    def __init__(self, session: Session, ws: WebSocket):
        self.session = session
        self.ws = ws
        self.send_lock = asyncio.Lock()
        self.closed = False

    async def send_json(self, msg: dict[str, Any]) -> None:
        async with self.send_lock:
            await self.ws.send_json(msg)

    async def send_bytes(self, data: bytes) -> None:
        async with self.send_lock:
            await self.ws.send_bytes(data)


class Streamer:
    def __init__(self, render, pool, max_jobs: int = 1, clock=time.monotonic, settings=None):
        from .settings import Settings
        self.settings = settings or Settings()
        self.render = render
        self.pool = pool
        self.max_jobs = max_jobs
        self.clock = clock
        self.clients: OrderedDict[str, Client] = OrderedDict()
        self.jobs = 0
        self.frames_sent = 0
        self._wake = asyncio.Event()
        self._task: asyncio.Task | None = None
        self._rr = 0

    def start(self) -> None:
        self._task = asyncio.get_running_loop().create_task(self._run(), name="fogbank-scheduler")

    async def stop(self) -> None:
        if self._task:
            self._task.cancel()
            try:
                await self._task
            except asyncio.CancelledError:
                pass

    def wake(self) -> None:
        self._wake.set()

    def add(self, client: Client) -> None:
        self.clients[client.session.id] = client
        self.wake()

    def remove(self, client: Client) -> None:
        client.closed = True
        self.clients.pop(client.session.id, None)
        sid = client.session.id
        self.render.submit(lambda r: r.drop_slot(sid))

    def _pick(self, now: float) -> tuple[Client | None, float | None]:
        """The next due client in round-robin order, else when the earliest one is due."""
        clients = list(self.clients.values())
        soonest = None
        for i in range(len(clients)):
            c = clients[(self._rr + i) % len(clients)]
            due = c.session.next_due(now)
            if due is None:
                continue
            if due <= now:
                self._rr = (self._rr + i + 1) % max(1, len(clients))
                return c, None
            soonest = due if soonest is None else min(soonest, due)
        return None, soonest

    async def _run(self) -> None:
        while True:
            self._wake.clear()
            now = self.clock()
            client, soonest = (None, None)
            if self.jobs < self.max_jobs:
                client, soonest = self._pick(now)
            if client is not None:
                job = client.session.start_frame(now)
                self.jobs += 1
                asyncio.get_running_loop().create_task(self._produce(client, job))
                continue
            timeout = None if soonest is None else max(0.0, soonest - now)
            try:
                await asyncio.wait_for(self._wake.wait(), timeout)
            except asyncio.TimeoutError:
                pass

    async def _produce(self, client: Client, job: FrameJob) -> None:
        s = client.session
        sent = False
        try:
            slot = s.id

            def draw(r):
                t0 = time.perf_counter()
                img = r.render(job.still, slot=slot, msaa=job.msaa)
                return img, (time.perf_counter() - t0) * 1000.0
            try:
                img, render_ms = await asyncio.wrap_future(self.render.submit(draw))
            finally:
                self.jobs -= 1
                self.wake()
            metrics.RENDER_MS.observe(render_ms)
            loop = asyncio.get_running_loop()
            t0 = time.perf_counter()
            data = await loop.run_in_executor(self.pool, encode, img, "jpg", job.quality)
            encode_ms = (time.perf_counter() - t0) * 1000.0
            metrics.ENCODE_MS.observe(encode_ms)
            flags = (FLAG_FULL if job.full else 0) | (FLAG_PLAYING if job.playing else 0)
            header = frame_header(job.frame, job.version, job.still.time, render_ms, encode_ms,
                                  job.still.width, job.still.height, job.quality, flags,
                                  job.still.effects.fog_scale)
            # a newer frame already went out (frames finish out of order when sizes or
            # encodes differ): this one is stale, drop it rather than show the past
            if not client.closed and job.frame > s.sent:
                s.sent = job.frame
                await client.send_bytes(header + data)
                sent = True
                self.frames_sent += 1
                metrics.FRAMES.inc()
        except Exception as exc:  # noqa: BLE001 - one frame fails, the session goes on
            if not client.closed:
                metrics.ERRORS.labels("frame").inc()
                log.warning("frame failed", extra={"session": s.id, "frame": job.frame, "error": str(exc)})
                try:
                    await client.send_json({"type": "error", "msg": f"frame {job.frame} failed: {exc}"})
                except Exception:  # noqa: BLE001
                    pass
        finally:
            s.frame_done(job, sent)
            self.wake()


class TokenBucket:
    """At most `rate` messages a second on average, `burst` at once."""

    def __init__(self, rate: float, burst: int, now: float):
        self.rate, self.burst, self.tokens, self.t = rate, burst, float(burst), now

    def take(self, now: float) -> bool:
        self.tokens = min(self.burst, self.tokens + (now - self.t) * self.rate)
        self.t = now
        if self.tokens >= 1.0:
            self.tokens -= 1.0
            return True
        return False


async def websocket_endpoint(ws: WebSocket, streamer: Streamer, renderer_info: dict) -> None:
    """/ws?<look query>: one session. See protocol.py for the messages."""
    cfg = streamer.settings
    await ws.accept()
    if len(streamer.clients) >= cfg.max_sessions:
        metrics.ERRORS.labels("sessions_full").inc()
        await ws.send_json({"type": "error", "msg": f"the server is full ({cfg.max_sessions} sessions); "
                            "retry in a few seconds", "retry_after": 5})
        await ws.close(code=1013, reason="try again later")
        return
    now = streamer.clock()
    bucket = TokenBucket(cfg.messages_per_s, cfg.message_burst, now)
    session = Session(uuid.uuid4().hex[:12], now)
    client = Client(session, ws)
    query = ws.url.query
    initial = session.apply(QueryMsg(type="query", query=query), now) if query else [session.state(now)]
    await client.send_json({"type": "hello", "protocol": PROTOCOL, "session": session.id,
                            "renderer": renderer_info.get("renderer"),
                            "max_message": MAX_MESSAGE})
    for out in initial:
        await client.send_json(out)
    streamer.add(client)
    log.info("session opened", extra={"session": session.id, "query": query})
    try:
        while True:
            msg = await ws.receive()
            if msg["type"] == "websocket.disconnect":
                break
            data = msg.get("text")
            if data is None:
                data = msg.get("bytes") or b""
            size = len(data.encode("utf-8")) if isinstance(data, str) else len(data)
            if size > MAX_MESSAGE:
                await ws.close(code=1009, reason=f"message over {MAX_MESSAGE} bytes")
                break
            if not bucket.take(streamer.clock()):
                metrics.ERRORS.labels("rate").inc()
                await client.send_json({"type": "error", "msg": f"over {cfg.messages_per_s:g} messages/s: "
                                        "message dropped", "loc": ["message"]})
                continue
            try:
                parsed = parse(data)
            except ProtocolError as exc:
                await client.send_json({"type": "error", "detail": exc.errors, "msg": str(exc)})
                continue
            for out in session.apply(parsed, streamer.clock()):
                await client.send_json(out)
            streamer.wake()
    except WebSocketDisconnect:
        pass
    finally:
        streamer.remove(client)
        log.info("session closed", extra={"session": session.id, "frames": session.sent})
        if ws.client_state == WebSocketState.CONNECTED:
            try:
                await ws.close()
            except Exception:  # noqa: BLE001
                pass
