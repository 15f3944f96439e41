"""Live frames over a WebSocket: the scheduler that shares the interactive render
workers among sessions, and the /ws endpoint.

Each session is pinned to one interactive worker (the one with the fewest sessions), so
its cached scene pass stays where its frames are drawn. The scheduler starts a frame for
the next due session in round-robin order, with at most `frames_per_worker` frames on
each worker (and one more for a stream that only plays: Streamer.queue_room). Each frame
is a snapshot of its session (latest wins); the worker renders and JPEG-encodes it, and
the bytes go out as header + JPEG. A session never has more than its window of frames
unacknowledged (two, and those one round trip holds: Session.window), so a slow client gets fewer frames, never older ones. The replies to
look changes wait in that window too (Client.owe): a camera message is answered with the
camera alone, and changes made while the window is full collapse into one reply.

A frame past its deadline kills its worker (the supervisor's rule). When the worker was
busy with it throughout, the look is too costly: the session that asked for it is paused
and told why, so one such look cannot keep killing the worker that every other session
shares. When the worker made no progress (stopped, hung: DeadlineExceeded.stalled), the
server is to blame: the session is told, and its frame is drawn again on the
replacement (up to STALL_RETRIES times in a row). Sessions that go quiet (no message for
`idle_timeout_s`) or stop acknowledging (`ack_timeout_s`) are closed with code 4408 and
a reason the page shows.
"""

from __future__ import annotations

import asyncio
import logging
import time
import uuid
from collections import Counter, OrderedDict
from typing import Any

from starlette.websockets import WebSocket, WebSocketDisconnect, WebSocketState

from fogbank.workers import cost

from fogbank.service import metrics
from fogbank.service.security import client_key

from fogbank.workers import worker
from fogbank.stream.protocol import (FLAG_FULL, FLAG_KEY, FLAG_PLAYING, FLAG_REDUCED, MAX_MESSAGE, PROTOCOL, HEADER,
                                     ProtocolError, QueryMsg, frame_header, parse)
from fogbank.stream.link import PING_EVERY_S
from fogbank.stream import live
from fogbank.stream.peer import TOO_LARGE, Peer, apply_change, next_message, refused_answers
from fogbank.stream.session import PLAY_BUDGET_MS, REFINE_BUDGET_MS, FrameJob, Session
from fogbank.workers.supervisor import DeadlineExceeded, Slot, Supervisor, WorkerError

log = logging.getLogger("fogbank.stream")


LINK_EVERY_S = 1.0   # the link's estimate is sent at most this often (a "link" message)
IDLE_CLOSE = 4408   # closed for inactivity (no messages, or frames left unacknowledged)
SHARE_RECENT_S = 1.0   # a playing session that started a frame this recently shares its worker (Streamer.sharing)
QUEUE_MAX_MS = 60.0   # a frame costlier than this is never queued behind another (Streamer.queue_room)
# frames of one session that may miss their deadline in a row on a stalled worker and be
# drawn again; past this the session is paused all the same (a worker that seems stalled
# each time, e.g. one waiting on a GPU without using the CPU, must not be killed forever)
STALL_RETRIES = 2
PENDING_RETRY_S = 0.1   # a frame whose worker was not ready (a noise tile baking) is asked again after this
# sessions share their worker by time: the due session whose frames have taken the least
# worker time goes first (a costly look's frames come less often, others' do not wait a
# turn per costly frame); one that was idle comes back at most this far ahead of the others
# (ms), so that a session paused for a minute does not then take the worker for a second
FAIR_SLACK_MS = 300.0
# ... and a frame longer than FAIR_FRAME_MS counts as more than its time, as many times
# more as it is longer (at most FAIR_MAX_FACTOR; fair_charge): a 640x360 stream at 30
# frames a second needs 0.8 of the worker, so equal shares beside a costly look left it
# 0.4-0.6 of its rate; the costly look is the one made slower (issue 33: at least 0.7
# kept). A 130 ms frame counts as 3 times its time; two equally costly looks still split
# the worker evenly. At most 8 times, a 16-layer look's 600 ms frames came 10 s apart
# beside a stream (its first frames take up to QUIET_FIRST_MS)
FAIR_FRAME_MS = 40.0
FAIR_MAX_FACTOR = 3.0
# a due session waits (the worker idle) up to this long for a session on its worker that has
# used less worker time and is due by then: a stream's next frame is due 33 ms after its
# last began, which took 26, and the 7 ms between went to a costly look's 130 ms frame
# every time (turns by frame again: 65 frames each in 10 s, tests/unit/test_streaming_scheduler.py)
FAIR_WAIT_S = 0.03
# ... but a session is held so at most this many times its last frame's time (or 1 s, not
# measured) at a time: a stream of cheap frames at 60 frames a second is always due within
# FAIR_WAIT_S, and a costly look whose frames count for more waited, the worker idle,
# until the stream's share caught up with its (tens of seconds). Held at most 4 frames'
# time, its frames take at least 1/5 of the worker while another session is always due
# (at 2.5, the difference view beside a stream took enough to leave it 0.66 of its rate)
FAIR_HOLD_FRAMES = 4.0
# ... and only while the worker would idle at most 1/this of the held frame's time (see
# _hold_until): a loaded machine's stream of 45 ms frames was held for 15 ms ones due 30 ms
# later, the worker a third idle
FAIR_HOLD_RATIO = 4.0


def fair_charge(ms: float) -> float:
    """What a frame of `ms` of worker time counts against its session's share."""
    return ms * min(FAIR_MAX_FACTOR, max(1.0, ms / FAIR_FRAME_MS))


class Client(Peer):
    """A session's own socket (its presenter, when it is shared live)."""

    def __init__(self, session: Session, ws: WebSocket, addr: str, now: float):
        super().__init__(session, ws)
        self.addr = addr
        self.slot: Slot | None = None
        self.last_message = now
        self.unacked_since: float | None = None   # oldest frame sent and not yet acknowledged
        self.stalls = 0   # frames in a row that missed their deadline on a stalled worker
        self.spoke = False   # has sent a message
        self.vtime = 0.0     # ms of worker time its frames took (Streamer._pick's fair share)
        self.held_since: float | None = None   # due, and held for a session due soon, since
        self.connected = now
        self.link_told = -1e9   # when the page was last told the link's estimate
        self.room: str | None = None   # the token its live link would have (stream/live.py)
        self.audience: live.Audience | None = None   # its viewers, while it is shared live

    def unacked(self) -> int:
        return self.session.sent - self.session.acked

    def window(self) -> int:
        return self.session.window()

    async def ping(self, now: float) -> None:
        await self.send_json({"type": "ping", "ping": self.session.link.ping(now)})


class Streamer:
    def __init__(self, workers: Supervisor, frames_per_worker: int = 1, clock=time.monotonic, settings=None):
        from fogbank.settings import Settings
        self.settings = settings or Settings()
        self.workers = workers
        self.frames_per_worker = frames_per_worker
        self.clock = clock
        self.clients: OrderedDict[str, Client] = OrderedDict()
        self.live: dict[str, Client] = {}   # live sessions by their token (stream/live.py)
        self.away: dict[str, live.Audience] = {}   # live sessions whose presenter is away, by its resume key
        self.watching: Counter[str] = Counter()   # live viewers' sockets by client (service/security.py client_key)
        self.frames: dict[int, int] = {}   # frames being made, by interactive worker index
        self._wake = asyncio.Event()
        self._tasks: list[asyncio.Task] = []
        self._rr = 0

    def start(self) -> None:
        loop = asyncio.get_running_loop()
        self._tasks = [loop.create_task(self._run(), name="fogbank-scheduler"),
                       loop.create_task(self._watch(), name="fogbank-idle-watch")]

    async def stop(self) -> None:
        for task in self._tasks:
            task.cancel()
            try:
                await task
            except asyncio.CancelledError:
                pass

    def wake(self) -> None:
        self._wake.set()

    def per_client(self, addr: str) -> int:
        return sum(1 for c in self.clients.values() if c.addr == addr)

    def idle_for(self, c: Client, now: float) -> float | None:
        """How long `c` has held its place without using the renderer, when that is long
        enough for it to give the place up (else None): a session that never sent a message
        after `silent_yield_s`, or one paused (time stopped, no drag) and quiet after
        `yield_after_s`. It costs a socket, not a render slot."""
        cfg = self.settings
        if c.audience is not None and c.audience.viewers:   # watched: a class listening to a paused look
            return None
        if not c.spoke:
            quiet = now - c.connected
            return quiet if quiet >= cfg.silent_yield_s else None
        if c.session.playing or c.session.previewing(now):
            return None
        quiet = now - c.last_message
        return quiet if quiet >= cfg.yield_after_s else None

    def make_room(self, now: float, addr: str | None = None) -> Client | None:
        """Admission by render capacity, not by sockets: when the server (or the address
        `addr`) is full, the session that has held its place longest without rendering
        (idle_for) gives it up: removed now, and returned so that the caller closes its
        socket (4408, resumed by the page on the next input). None: no session can yield."""
        idle = [(q, c) for c in self.clients.values() if (addr is None or c.addr == addr)
                and (q := self.idle_for(c, now)) is not None]
        if not idle:
            return None
        quiet, victim = max(idle, key=lambda qc: qc[0])
        metrics.ERRORS.labels("yielded").inc()
        log.info("session yielded its place", extra={"session": victim.session.id, "quiet_s": round(quiet, 1)})
        self.remove(victim)
        return victim

    def add(self, client: Client) -> None:
        slot = self.workers.interactive.least_loaded("sessions")
        slot.sessions += 1
        client.slot = slot
        client.vtime = min((c.vtime for c in self.clients.values() if c.slot is slot), default=0.0)
        self.clients[client.session.id] = client
        self.wake()

    def remove(self, client: Client) -> None:
        client.closed = True
        if self.clients.pop(client.session.id, None) is not None and client.slot is not None:
            client.slot.sessions -= 1
            asyncio.get_running_loop().create_task(self._drop(client.slot, client.session.id))

    async def _drop(self, slot: Slot, sid: str) -> None:
        """Free the session's cached scene pass on its worker."""
        try:
            await self.workers.call(slot, worker.drop_slot, sid, deadline=self.settings.frame_deadline_s)
        except Exception:  # noqa: BLE001 - a dead worker has nothing left to free
            pass

    def queue_room(self, client: Client, now: float) -> int:
        """How many frames may be on the worker when one of `client`'s starts:
        `frames_per_worker`, and one more for a stream that only plays. A frame queued
        behind the one being drawn starts the moment that one ends, so the worker does not
        idle through the hand-over between frames (the result's trip to this process, the
        next job's back: 4-6 ms a frame here), at a frame of latency. Not for a preview (a
        drag's frame shows the newest camera); not while another session on the worker
        previews (its preview starts only on an idle worker, which a playing stream would
        keep full); not before a full frame at the session's refinement level is measured,
        nor when it takes over QUEUE_MAX_MS: a preview that input starts can wait behind the
        queued frame, so that is the most latency the queue adds to it (a look of 16 layers
        whose full frames took 700 ms kept a drag's first previews 1.4 s behind), and a look
        that passes the frame deadline never has a second frame waiting to run on the
        restarted worker. A preview's cost says nothing of a full frame's, nor does another
        level's: a look's first full frames compiled programs (not measured), its 39 ms
        previews stood for them, and two of its 380 ms frames ran back to back while a
        drag's first change waited 690 ms for both."""
        s = client.session
        room = self.frames_per_worker
        if (s.previewing(now) or s.last_ms is None or s.last_ms > QUEUE_MAX_MS
                or s.last_level != s.refine_level):
            return room
        if any(c is not client and c.slot is client.slot and c.session.previewing(now)
               for c in self.clients.values()):
            return room
        return room + 1

    def sharing(self, client: Client, now: float) -> int:
        """How many sessions on `client`'s worker draw frames in turn (preview, or play
        and started a frame within SHARE_RECENT_S: a playing session whose client does not
        acknowledge its frames draws none), `client`'s included."""
        return 1 + sum(1 for c in self.clients.values() if c is not client and c.slot is client.slot
                       and (c.session.previewing(now)
                            or (c.session.playing and now - c.session.last_start < SHARE_RECENT_S)))

    def _pick(self, now: float) -> tuple[Client | None, float | None]:
        """The next due client whose worker has room, in round-robin order, else when the
        earliest one is due. A worker's queued frame (queue_room's one more) goes only to a
        session when no other session on that worker is due: a playing stream that kept its
        worker full took every place freed by its own frames, and the other sessions on the
        worker got none (4 clients on one worker: two got 0 frames a second)."""
        clients = list(self.clients.values())
        order = [clients[(self._rr + i) % len(clients)] for i in range(len(clients))]
        # by time: the least worker time used first (round-robin order among equals); a
        # session back from idle starts no further than FAIR_SLACK_MS behind those that kept
        # drawing on its worker
        floor: dict[int, float] = {}
        for c in order:
            if now - c.session.last_start < SHARE_RECENT_S:
                floor[c.slot.index] = min(floor.get(c.slot.index, c.vtime), c.vtime)
        for c in order:
            if c.slot.index in floor:
                c.vtime = max(c.vtime, floor[c.slot.index] - FAIR_SLACK_MS)
        order.sort(key=lambda c: c.vtime)
        soonest = None
        waiting: set[int] = set()   # workers with a due session that its room holds back
        holding: dict[int, list] = {}   # worker -> (when due, last frame's ms) of sessions that used less time, due within FAIR_WAIT_S
        queued: list[Client] = []   # due sessions that may take a worker's queued place
        for c in order:
            due = c.session.next_due(now)
            if due is None:
                continue
            if due > now:
                soonest = due if soonest is None else min(soonest, due)
                if due - now <= FAIR_WAIT_S:   # the costly sessions after it on its worker wait for it
                    holding.setdefault(c.slot.index, []).append((due, c.session.last_ms))
                continue
            until = self._hold_until(c, holding.get(c.slot.index, ()), now)
            if until is not None:
                soonest = until if soonest is None else min(soonest, until)
                continue
            on = self.frames.get(c.slot.index, 0)
            if on < self.frames_per_worker:
                return self._picked(c, clients), None
            if on < self.queue_room(c, now):
                queued.append(c)
            else:
                waiting.add(c.slot.index)
        for c in queued:   # in the same order (by worker time used): playing streams take turns
            if c.slot.index not in waiting:
                return self._picked(c, clients), None
        return None, soonest

    @staticmethod
    def _hold_until(c: Client, others, now: float) -> float | None:
        """Until when due `c` waits for a session on its worker that used less time and is
        due soon (`others`: (when due, its last frame's ms) of each; None: it goes now):
        only a frame costlier than FAIR_FRAME_MS that would still run when the other is
        due, and only while the worker would idle at most 1/FAIR_HOLD_RATIO of that frame's
        time waiting; not a preview (a drag's change must show); and for at most
        FAIR_HOLD_FRAMES of its frames' time at a stretch (1 s before one is measured). Two
        cheap streams held each other for nothing: one of 10 ms frames beside one at 60
        frames a second drew 12 frames a second of its 30, the worker idle; and on a loaded
        machine, a 640x360 stream whose frames took 45 ms was held for a look's 15 ms ones
        due 30 ms later, the worker idle a third of the time: it kept 0.32 of its rate
        (tests/unit/test_streaming_scheduler.py)."""
        last = c.session.last_ms
        if c.session.previewing(now) or (last is not None and last <= FAIR_FRAME_MS):
            c.held_since = None
            return None
        wait = 1.0 if last is None else last / 1000.0 / FAIR_HOLD_RATIO
        other_due = min((due for due, _ in others if due - now <= wait), default=None)
        if other_due is None or (last is not None and now + last / 1000.0 <= other_due):
            c.held_since = None
            return None
        if c.held_since is None:
            c.held_since = now
        end = c.held_since + (1.0 if last is None else FAIR_HOLD_FRAMES * last / 1000.0)
        if now >= end:
            return None
        return min(other_due, end)

    def _picked(self, c: Client, clients: list[Client]) -> Client:
        self._rr = (clients.index(c) + 1) % len(clients)
        c.held_since = None
        return c

    async def _run(self) -> None:
        while True:
            self._wake.clear()
            now = self.clock()
            client, soonest = self._pick(now)
            if client is not None:
                job = client.session.start_frame(now, self.sharing(client, now))
                self.frames[client.slot.index] = self.frames.get(client.slot.index, 0) + 1
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
        slot = client.slot
        try:
            try:
                out = await self.workers.call(slot, worker.frame, job.still, s.id, job.msaa, job.quality,
                                              job.show, job.layer, job.hold_fog, not job.full,
                                              job.codec, job.bitrate, job.keyframe,
                                              deadline=self.settings.frame_deadline_s)
                if not out.get("pending"):
                    slot.drew(cost.program_key(job.still))
            finally:
                self.frames[slot.index] -= 1
                self.wake()
            if out.get("pending"):   # its noise tile bakes on the worker's thread: ask again soon
                s.redo(after=self.clock() + PENDING_RETRY_S)
                return
            render_ms, encode_ms = out["render_ms"], out["encode_ms"]
            client.stalls = 0
            client.vtime += fair_charge(render_ms + encode_ms)
            s.measured(job, render_ms, self.clock(), once=bool(out.get("once")),
                       scene_reused=out.get("scene_reused"), scene_warped=bool(out.get("scene_warped")))
            metrics.RENDER_MS.observe(render_ms)
            metrics.ENCODE_MS.observe(encode_ms)
            flags = ((FLAG_FULL if job.full else 0) | (FLAG_PLAYING if job.playing else 0)
                     | (FLAG_REDUCED if job.reduced else 0) | (FLAG_KEY if out.get("key") else 0))
            header = frame_header(job.frame, job.version, job.still.time, render_ms, encode_ms,
                                  job.still.width, job.still.height, job.quality, flags,
                                  job.still.effects.fog_scale, job.codec)
            # a newer frame already went out (frames finish out of order when sizes or
            # encodes differ): this one is stale, drop it rather than show the past
            if not client.closed and job.frame > s.sent:
                idle = s.sent == s.acked   # no frame on the link
                s.sent = job.frame
                now = self.clock()
                await client.pay(now, force=True)   # the look's reply before its frame
                if idle and now - s.link.last_ping >= PING_EVERY_S:
                    await client.ping(now)   # a clean round trip (stream/link.py)
                if now - client.link_told >= LINK_EVERY_S and s.link.rate_bps() is not None:
                    client.link_told = now   # what the link carries, for the page's overlay
                    await client.send_json({"type": "link", "rate_bps": round(s.link.rate_bps()),
                                            "rtt_ms": round((s.link.rtt_s() or 0.0) * 1000, 1),
                                            "stream_bps": round(s.link.stream_bps(now)),
                                            "limiting": s.link.limiting})
                # frames come every 1/fps of the view, or every render where that is longer
                s.link.sent(job.frame, HEADER.size + len(out["data"]), now,
                            max(1.0 / s.view.fps, (render_ms + encode_ms) / 1000.0))
                if job.codec == "jpeg":   # the JPEG sizes that FrameFit predicts from
                    s.fit.encoded(len(out["data"]), job.still.width * job.still.height, job.quality)
                # a view that teaches: its numbers and legend first
                stats = {"type": "view_stats", "frame": job.frame, **out["stats"]} if out.get("stats") else None
                packet = header + out["data"]
                if stats:
                    await client.send_json(stats)
                await client.send_bytes(packet)
                if client.audience is not None:   # the same bytes to its viewers (stream/live.py)
                    await client.audience.fan_out(job.frame, job.codec, bool(out.get("key")), packet, stats, now)
                if client.unacked_since is None:
                    client.unacked_since = self.clock()
                sent = True
                metrics.FRAMES.inc()
            elif job.codec != "jpeg":   # a video frame dropped: the next one stands alone
                s.need_key = True
        except DeadlineExceeded as exc:
            metrics.ERRORS.labels("frame_deadline").inc()
            deadline = self.settings.frame_deadline_s
            if exc.stalled and client.stalls < STALL_RETRIES:
                client.stalls += 1
                s.redo()
                log.warning("frame's worker stalled; drawn again on its replacement",
                            extra={"session": s.id, "frame": job.frame, "cpu_share": exc.cpu_share})
                await self._tell(client, {"type": "error", "retry_after": exc.retry_after,
                                          "msg": f"the renderer stalled during frame {job.frame} (it made no "
                                                 f"progress for {deadline:g} s) and was replaced; the stream "
                                                 "goes on"})
                return
            log.warning("frame past its deadline; session paused",
                        extra={"session": s.id, "frame": job.frame, "cpu_share": exc.cpu_share})
            s.pause(self.clock())
            await self._tell(client, s.state(self.clock()))
            if exc.stalled:
                why = (f"the renderer stalled on {client.stalls + 1} frames of this look in a row (each over "
                       f"{deadline:g} s with no progress), so the stream is paused; change the look or "
                       "press play to try again")
            else:
                busy = "" if exc.cpu_share is None else f" (the renderer busy throughout: {exc.cpu_share:.1f} cores)"
                why = (f"this look took over {deadline:g} s a frame{busy}, so the stream is paused: make it "
                       "cheaper (fewer or cheaper layers, fewer volume samples, a larger effects.fog_scale or "
                       "a smaller view)")
            client.stalls = 0
            await self._tell(client, {"type": "error", "loc": ["params"], "retry_after": exc.retry_after,
                                      "msg": why})
        except Exception as exc:  # noqa: BLE001 - one frame fails, the session goes on
            metrics.ERRORS.labels("frame").inc()
            log.warning("frame failed", extra={"session": s.id, "frame": job.frame, "error": str(exc)})
            msg = str(exc) if isinstance(exc, WorkerError) else f"{type(exc).__name__}: {exc}"
            if isinstance(exc, WorkerError) and exc.status == 503 and client.stalls < STALL_RETRIES:
                client.stalls += 1   # the worker died or was replaced: the frame again, on the new one
                s.redo()
                msg += "; it is drawn again"
            await self._tell(client, {"type": "error", "msg": f"frame {job.frame} failed: {msg}"})
        finally:
            s.frame_done(job, sent)
            self.wake()

    async def _tell(self, client: Client, msg: dict[str, Any]) -> None:
        if client.closed:
            return
        try:
            await client.send_json(msg)
        except Exception:  # noqa: BLE001 - the client is gone
            pass

    async def _watch(self) -> None:
        """Close sessions that went quiet or stopped acknowledging frames."""
        cfg = self.settings
        while True:
            await asyncio.sleep(min(1.0, cfg.idle_timeout_s / 4, cfg.ack_timeout_s / 4))
            now = self.clock()
            live.expire_away(self, now)   # presenters that did not come back
            for c in list(self.clients.values()):
                # a session with viewers is not idle while they watch (a class listening to
                # its teacher over a paused look sends nothing); its viewers go with it
                watched = c.audience is not None and bool(c.audience.viewers)
                for v in list(c.audience.viewers.values()) if c.audience else []:
                    # a viewer that leaves its frames unacknowledged is let go, as a session is
                    if v.inflight and now - min(v.inflight.values()) > cfg.ack_timeout_s:
                        why = f"frames unacknowledged for {cfg.ack_timeout_s:g} s"
                        log.info("viewer closed", extra={"session": c.session.id, "viewer": v.id, "reason": why})
                        c.audience.leave(v, now)
                        v.close(IDLE_CLOSE, why)
                        await c.audience.tell()
                reason = None
                if now - c.last_message > cfg.idle_timeout_s and not watched:
                    reason = f"idle: no message for {cfg.idle_timeout_s:g} s"
                elif c.unacked_since is not None and now - c.unacked_since > cfg.ack_timeout_s:
                    reason = f"frames unacknowledged for {cfg.ack_timeout_s:g} s"
                if reason:
                    metrics.ERRORS.labels("idle").inc()
                    log.info("session closed", extra={"session": c.session.id, "reason": reason})
                    self.remove(c)
                    try:
                        await c.ws.close(code=IDLE_CLOSE, reason=reason)
                    except Exception:  # noqa: BLE001 - already gone
                        pass


class TokenBucket:
    """At most `rate` messages a second on average, `burst` at once. `should_notify`
    says whether a dropped message is the first since the bucket last had room: the
    client is told once per window of overflow, then messages drop silently."""

    def __init__(self, rate: float, burst: int, now: float):
        self.rate, self.burst, self.tokens, self.t = rate, burst, float(burst), now
        self._notified = False

    def take(self, now: float) -> bool:
        self.tokens = min(self.burst, self.tokens + (now - self.t) * self.rate)
        self.t = now
        if self.tokens >= 1.0:
            self.tokens -= 1.0
            if self.tokens >= self.burst / 2:   # the overflow is over: a new one is told again
                self._notified = False
            return True
        return False

    def should_notify(self) -> bool:
        if self._notified:
            return False
        self._notified = True
        return True


_YIELDING: set = set()


def _room(streamer: Streamer, now: float, addr: str | None, yielded: list) -> bool:
    victim = streamer.make_room(now, addr)
    if victim is not None:
        yielded.append(victim)
    return victim is not None


async def _yield(c: Client, now: float) -> None:
    quiet = now - (c.last_message if c.spoke else c.connected)
    reason = (f"gave its place to a new session after {quiet:.0f} s "
              + ("without a message" if not c.spoke else "paused"))
    try:
        await c.ws.close(code=IDLE_CLOSE, reason=reason)
    except Exception:  # noqa: BLE001 - already gone
        pass


async def websocket_endpoint(ws: WebSocket, streamer: Streamer, renderer_info: dict) -> None:
    """/ws?<look query>: one session. See protocol.py for the messages."""
    cfg = streamer.settings
    await ws.accept()
    addr = client_key(ws.client.host) if ws.client else "?"   # what per-client caps count by
    query, room, token = live.split_live(ws.url.query)
    query, resume = live.take_resume(query)
    if token is not None:   # a viewer of a live session: no session, no render of its own
        await live.viewer_endpoint(ws, streamer, token, addr, renderer_info, room)
        return
    refusal = None
    yielded: list[Client] = []
    # check and register with no await in between: sessions connecting at once must not
    # all pass the caps before any of them is counted
    now = streamer.clock()
    if streamer.per_client(addr) >= cfg.max_sessions_per_client and not _room(streamer, now, addr, yielded):
        metrics.ERRORS.labels("sessions_per_client").inc()
        refusal = (f"this address already has {cfg.max_sessions_per_client} sessions open; close one "
                   "(another tab or window) or retry later")
    elif len(streamer.clients) >= cfg.max_sessions and not _room(streamer, now, None, yielded):
        metrics.ERRORS.labels("sessions_full").inc()
        refusal = f"the server is full ({cfg.max_sessions} sessions); retry in a few seconds"
    for c in yielded:
        task = asyncio.get_running_loop().create_task(_yield(c, now))
        _YIELDING.add(task)   # kept until done: the loop holds only a weak reference
        task.add_done_callback(_YIELDING.discard)
    if refusal:
        try:
            await ws.send_json({"type": "error", "msg": refusal, "retry_after": 5})
            await ws.close(code=1013, reason="try again later")
        except WebSocketDisconnect:
            pass   # it left first
        return
    now = streamer.clock()
    bucket = TokenBucket(cfg.messages_per_s, cfg.message_burst, now)
    session = Session(uuid.uuid4().hex[:12], now)
    client = Client(session, ws, addr, now)
    client.room = room
    streamer.add(client)
    try:
        initial = session.apply(QueryMsg(type="query", query=query), now) if query else [session.state(now)]
        await client.send_json({"type": "hello", "protocol": PROTOCOL, "session": session.id,
                                "renderer": renderer_info.get("renderer"),
                                "max_message": MAX_MESSAGE,
                                # what a final frame may cost before it is reduced (the page says so)
                                "refine_budget_ms": REFINE_BUDGET_MS, "play_budget_ms": PLAY_BUDGET_MS})
        for out in initial:
            await client.send_json(out)
    except WebSocketDisconnect:   # the client left during the handshake: nothing went wrong here
        streamer.remove(client)
        log.info("session closed during its handshake", extra={"session": session.id})
        return
    except Exception:
        streamer.remove(client)
        raise
    log.info("session opened", extra={"session": session.id, "query": query})
    if resume and live.resume_live(client, streamer, resume, now):   # its live session, back after a blip
        await client.audience.tell()
        streamer.wake()
    try:
        while True:
            data = await next_message(ws)
            if data is None:
                break
            if data is TOO_LARGE:
                await ws.close(code=1009, reason=f"message over {MAX_MESSAGE} bytes")
                break
            client.last_message = streamer.clock()
            client.spoke = True
            if not bucket.take(streamer.clock()):
                metrics.ERRORS.labels("rate").inc()
                if bucket.should_notify():
                    await client.send_json({"type": "error", "msg": f"over {cfg.messages_per_s:g} messages/s: "
                                            "messages are dropped until the rate falls", "loc": ["message"]})
                continue
            try:
                parsed = parse(data)
            except ProtocolError as exc:
                await client.answer_error({"type": "error", "detail": exc.errors, "msg": str(exc)},
                                          refused_answers(data), streamer.clock())
                continue
            acked = session.acked
            if not await live.presenter_message(client, parsed, streamer, streamer.clock()):
                await apply_change(session, parsed, client, client.audience.others(client) if client.audience else [],
                                   streamer.clock())
            if session.acked != acked:   # progress: the oldest unacknowledged frame is newer
                client.unacked_since = None if session.acked >= session.sent else streamer.clock()
            streamer.wake()
    except WebSocketDisconnect:
        pass
    finally:
        streamer.remove(client)
        live.presenter_left(client, streamer, streamer.clock())
        log.info("session closed", extra={"session": session.id, "frames": session.sent})
        if ws.client_state == WebSocketState.CONNECTED:
            try:
                await ws.close()
            except Exception:  # noqa: BLE001
                pass
