"""Live sessions (issue 34): one session's frames, drawn and encoded once, sent to every
viewer of its live link.

The presenter's page connects with `room=<token>` beside its look: a random key that the
load balancer routes /ws by (docker/nginx/fogbank.conf hashes `live` and `room`), and which
"share" makes the live link's token. A viewer connects with `live=<token>` alone and so
reaches the replica that holds the session (the page gives `room=<its room>` beside it,
for a load balancer that hashes by `room` alone). A token is 16-64 URL-safe characters; a
presenter that gave none (or one in use) is given a random one, reachable directly.

A viewer gets the presenter's frames as they are (its codec, size and quality), the look's
state and camera replies, and "audience" messages (how many watch, who has control). It
costs no render and no encode: its frames are the presenter's bytes. Each viewer has its
own window (MAX_IN_FLIGHT frames unacknowledged) and its own sender task, so a slow viewer
never slows the presenter or the others: it skips frames, and in video then waits for the
next keyframe, which the session is asked for at most every KEY_EVERY_S. A new viewer gets
a keyframe at once, and a paused look's frame is drawn again for it. What a viewer has
queued is bounded (its window's frames, one owed reply, one audience message, and at most
MAX_QUEUED texts): one that stops reading is closed.

The presenter can hand control to a viewer ("control"): then that viewer's look changes
apply to the session (and the presenter's do not) until the presenter takes it back or the
viewer gives it back. A presenter who leaves or stops sharing ends the session for its
viewers: an "ended" message with the reason, then close code 4410; a presenter whose
socket drops (a blip) is waited for live_resume_s (its viewers told it is away), and its
page, reconnecting with its room and the resume key only it was given, takes the session
back (resume_live). A viewer who leaves costs nothing.
"""

from __future__ import annotations

import asyncio
import json
import logging
import math
import re
import secrets
import uuid
from collections import deque
from typing import TYPE_CHECKING, Any

from starlette.websockets import WebSocket, WebSocketDisconnect

from fogbank.service import metrics
from fogbank.stream.peer import (LOOK_CHANGES, STEERING, TOO_LARGE, Peer, apply_change, next_message,
                                 refused_answers)
from fogbank.stream.protocol import (MAX_MESSAGE, PROTOCOL, AckMsg, ControlMsg, InteractMsg, PongMsg, ProtocolError,
                                     ShareMsg, ViewMsg, parse)
from fogbank.stream.link import pipe_frames
from fogbank.stream.session import MAX_IN_FLIGHT, PLAY_BUDGET_MS, REFINE_BUDGET_MS, VIEW_WAIT_S, Session

if TYPE_CHECKING:
    from fogbank.stream.streaming import Client

log = logging.getLogger("fogbank.stream")

ENDED_CLOSE = 4410   # the live session ended (the presenter left or stopped sharing)
NO_SUCH_CLOSE = 4404   # no live session has this token (here)
ROOM = re.compile(r"[A-Za-z0-9_-]{16,64}")
# a live link's token: the presenter's room (what the load balancer routes by) and a random
# part that only the server makes, so that no one who saw a link can claim it by
# connecting with its room once the presenter is gone
TOKEN = re.compile(r"[A-Za-z0-9_-]{16,64}(\.[A-Za-z0-9_-]{16})?")
FORCE_CLOSE_S = 5.0   # a viewer's socket that does not take its close within this is dropped
KEY_EVERY_S = 1.0    # a viewer that skipped video frames waits for a keyframe asked at most this often
# a viewer is told who watches at most this often (when a class of N leaves at once, each
# of them would otherwise be sent up to N messages)
AUDIENCE_EVERY_S = 0.25
MAX_QUEUED = 64      # texts a viewer may leave unread (its errors, mostly) before it is closed


def split_live(query: str) -> tuple[str, str | None, str | None]:
    """The look's query, and the `room` and `live` tokens beside it (None: absent). A
    `live` that is not a token is returned as it is (the caller refuses it), and one given
    more than once as all of its values joined by "&" (refused too: the load balancer
    routes by the first, and the server would read another); a `room` that is not one, or
    is given more than once, is dropped (the session is given a token when shared)."""
    look, rooms, lives = [], [], []
    for part in query.split("&") if query else []:
        if part.startswith("room="):
            rooms.append(part[5:])
        elif part.startswith("live="):
            lives.append(part[5:])
        elif part:
            look.append(part)
    room = rooms[0] if len(rooms) == 1 and ROOM.fullmatch(rooms[0]) else None
    return "&".join(look), room, "&".join(lives) if lives else None


def take_resume(query: str) -> tuple[str, str | None]:
    """The look's query without `resume=<key>` (a presenter's page reconnecting to its live
    session: resume_live), and the key (None: absent or not one)."""
    parts = query.split("&") if query else []
    keys = [p[7:] for p in parts if p.startswith("resume=")]
    rest = "&".join(p for p in parts if not p.startswith("resume="))
    return rest, keys[0] if len(keys) == 1 and ROOM.fullmatch(keys[0]) else None


_DROPPING: set = set()   # viewers' forced closes under way (the loop keeps weak references)


class Viewer(Peer):
    """A viewer's socket: its messages go out in order from its own task (`_run`)."""

    def __init__(self, vid: str, session: Session, ws: WebSocket, addr: str):
        super().__init__(session, ws)
        self.id, self.addr = vid, addr
        self.inflight: dict[int, float] = {}   # frame id -> when sent, not yet acknowledged
        self.waiting_key = True   # video frames wait for a keyframe (a new viewer, or one that skipped)
        self.codecs: tuple[str, ...] = ("jpeg",)   # what its page decodes (its view message)
        self.told_codecs = False   # its first view message (as it joins) came
        self.rtt = math.inf        # the least ack time of its frames, s (ack)
        self.joined = 0.0          # when it joined its audience (Audience.join)
        self.frames = 0    # frames sent to it
        self.last_frame = 0   # the id of the last frame given it
        self.queued_frames = 0   # frames given it and not yet written to its socket
        self.skipped = 0   # frames it did not get (its window full, or waiting for a keyframe)
        self.audience_due = False   # an "audience" message is owed (built when it goes)
        self.audience_told = -math.inf   # when it was last sent one (loop time)
        self._out: deque[tuple[str, Any]] = deque()
        self._wake = asyncio.Event()
        self._close: tuple[int, str] | None = None
        self._task: asyncio.Task | None = None

    def unacked(self) -> int:
        return len(self.inflight)

    def ack(self, frame: int, now: float | None = None) -> None:
        """Frames up to `frame` arrived (an ack past the last frame given it is ignored, as
        the session's own are: it would free a window that its socket still holds). With
        `now`, the frame's ack time is a bound on the viewer's round trip (its transfer in
        it): the least of them is the round trip its window holds (window)."""
        if frame > self.last_frame:
            return
        for f in [f for f in self.inflight if f <= frame]:
            sent = self.inflight.pop(f)
            if now is not None and f == frame:
                self.rtt = min(self.rtt, now - sent)

    def window(self) -> int:
        """Frames that may be unacknowledged: two, and those one round trip of its own holds
        at the stream's interval, as the presenter's (session.py Session.window): a viewer
        as far away as its presenter keeps its frame rate."""
        return MAX_IN_FLIGHT + pipe_frames(self.rtt, self.session.link.interval)

    def room(self) -> bool:
        """Room for a frame: fewer than its window unacknowledged, and at most MAX_IN_FLIGHT
        waiting to be written (a socket that does not drain holds them, whatever is
        acknowledged)."""
        return self.unacked() < self.window() and self.queued_frames < MAX_IN_FLIGHT

    async def send_json(self, msg: dict[str, Any]) -> None:
        self._put("text", json.dumps(msg))

    async def send_bytes(self, data: bytes) -> None:
        self._put("bytes", data)

    def _put(self, kind: str, data: Any) -> None:
        if self.closed or self._close:
            return
        if kind == "text" and len(self._out) - self.queued_frames >= MAX_QUEUED:
            self.close(1008, "messages left unread")
            return
        self._out.append((kind, data))
        if kind == "bytes":
            self.queued_frames += 1
        self._wake.set()

    def close(self, code: int, reason: str) -> None:
        """Close after what is queued; a socket that does not take it within FORCE_CLOSE_S
        (its reader stopped, the writes block) is dropped."""
        if self._close is None:
            self._close = (code, reason)
            self._wake.set()
            asyncio.get_running_loop().call_later(FORCE_CLOSE_S, self._force)

    def _force(self) -> None:
        if self._task is not None and not self._task.done():
            self._task.cancel()
            task = asyncio.get_running_loop().create_task(self._drop())
            _DROPPING.add(task)
            task.add_done_callback(_DROPPING.discard)

    async def _drop(self) -> None:
        try:
            await asyncio.wait_for(self.ws.close(code=self._close[0], reason=self._close[1]), 1.0)
        except Exception:  # noqa: BLE001 - gone, or its socket blocked: its endpoint ends on disconnect
            pass

    def start(self, audience: "Audience") -> None:
        self._task = asyncio.get_running_loop().create_task(self._run(audience), name=f"fogbank-viewer-{self.id}")

    async def _run(self, audience: "Audience") -> None:
        loop = asyncio.get_running_loop()
        try:
            while True:
                await self._wake.wait()
                self._wake.clear()
                while True:
                    if self._out:   # in order; then the audience as it is now
                        kind, data = self._out.popleft()
                        if kind == "text":
                            await self.ws.send_text(data)
                        else:
                            await self.ws.send_bytes(data)
                            self.queued_frames -= 1
                    elif self.audience_due and not self._close:
                        wait = self.audience_told + AUDIENCE_EVERY_S - loop.time()
                        if wait > 0:   # again once it is due
                            loop.call_later(wait, self._wake.set)
                            break
                        self.audience_due = False
                        self.audience_told = loop.time()
                        await self.ws.send_text(json.dumps(audience.message(self)))
                    else:
                        break
                if self._close:
                    await self.ws.close(code=self._close[0], reason=self._close[1])
                    return
        except asyncio.CancelledError:
            raise
        except Exception:  # noqa: BLE001 - the viewer is gone; its endpoint removes it
            pass
        finally:
            self.closed = True
            self._out.clear()

    async def stop(self) -> None:
        if self._task is not None and not self._task.done():
            self._task.cancel()
            try:
                await self._task
            except asyncio.CancelledError:
                pass


class Audience:
    """The viewers of one presenter's session, and who has control (None: the presenter)."""

    def __init__(self, presenter: "Client", token: str):
        self.presenter = presenter
        self.token = token
        self.viewers: dict[str, Viewer] = {}
        self.control: str | None = None
        self.key_asked = -math.inf
        # the presenter's alone: its page reconnects with it (`resume=`) after a blip, and
        # the viewers, who know the token, cannot take the session over with it
        self.resume_key = secrets.token_urlsafe(16)
        self.away_since: float | None = None   # the presenter's socket ended then (not yet back)
        self.ended = False

    @property
    def session(self) -> Session:
        return self.presenter.session

    def message(self, peer: Peer) -> dict[str, Any]:
        presenter = peer is self.presenter
        msg = {"type": "audience", "role": "presenter" if presenter else "viewer", "token": self.token,
               "viewers": len(self.viewers), "control": self.control,
               "you": None if presenter else getattr(peer, "id", None), "away": self.away_since is not None}
        if presenter:
            msg["ids"] = list(self.viewers)
            msg["resume"] = self.resume_key
        return msg

    async def tell(self) -> None:
        """Everyone is told who watches and who has control (a viewer's message is built
        when its turn comes, so that several changes send one)."""
        for v in self.viewers.values():
            v.audience_due = True
            v._wake.set()
        if not self.presenter.closed:
            try:
                await self.presenter.send_json(self.message(self.presenter))
            except Exception:  # noqa: BLE001 - the presenter is gone; its endpoint ends this
                pass

    def others(self, peer: Peer) -> list[Peer]:
        """The sockets told of a change that `peer` made (answers 0)."""
        out: list[Peer] = [v for v in self.viewers.values() if v is not peer]
        if peer is not self.presenter:
            out.append(self.presenter)
        return out

    def controls(self, peer: Peer) -> bool:
        if peer is self.presenter:
            return self.control is None
        return self.control == getattr(peer, "id", None)

    def _intersection(self, now: float) -> frozenset | None:
        """What every viewer decodes (None: no viewer counts). A viewer counts once it has
        said what it decodes (its first view message, as it joins), or once it has been
        silent for VIEW_WAIT_S (then its JPEG): a joining page does not narrow everyone's
        codec for the moment before its view message comes."""
        counted = [frozenset(v.codecs) for v in self.viewers.values()
                   if v.told_codecs or now - v.joined >= VIEW_WAIT_S]
        return frozenset.intersection(*counted) if counted else None

    def _codecs(self) -> None:
        """The session's video codec must be one every viewer decodes (else JPEG): at once."""
        self.session.decoders = self._intersection(math.inf)

    def _ask_key(self, now: float) -> None:
        """A keyframe for the viewers waiting for one, at most every KEY_EVERY_S (fan_out asks
        again for those still waiting when it is due)."""
        if now - self.key_asked >= KEY_EVERY_S:
            self.key_asked = now
            self.session.need_key = True

    def join(self, viewer: Viewer, now: float) -> None:
        """A new viewer. Its codecs, and the keyframe it starts on, come with its first view
        message (set_codecs); a paused look is drawn again for it (a JPEG frame)."""
        viewer.joined = now
        self.viewers[viewer.id] = viewer
        metrics.VIEWERS.inc()
        if not self.session.playing:
            self.session.redo()

    def leave(self, viewer: Viewer, now: float | None = None) -> bool:
        """A viewer left: the session's codecs may widen, at the pace of KEY_EVERY_S (`now`
        None: at once, as the session ends)."""
        if self.viewers.pop(viewer.id, None) is None:
            return False
        metrics.VIEWERS.dec()
        if self.control == viewer.id:
            self.hand(None)
        if now is None:
            self._codecs()
        else:
            self._settle_codecs(now)
        return True

    def hand(self, to: str | None) -> None:
        """Control to viewer `to` (None: the presenter). A drag of whoever had it ends with it
        (else the look stayed in its previews until the next one in control dragged)."""
        if to != self.control:
            self.control = to
            self.session.interacting = False

    def set_codecs(self, viewer: Viewer, codecs: tuple[str, ...], now: float) -> None:
        """A viewer says what it decodes (its view messages): a first word or a change
        restarts its decoder, so it waits for a keyframe, asked at the pace of KEY_EVERY_S
        like everything else (a page joining in a loop asked one each time)."""
        first, viewer.told_codecs = not viewer.told_codecs, True
        if first or codecs != viewer.codecs:
            viewer.codecs = codecs
            viewer.waiting_key = True
            self._settle_codecs(now)
            self._ask_key(now)

    def _settle_codecs(self, now: float) -> None:
        """The session's codecs follow what its viewers decode, changed (a new encoder and a
        keyframe for everyone) only when that set changes, at most every KEY_EVERY_S: a
        viewer that flipped its codecs in every message, or viewers joining and leaving in a
        loop, forced a keyframe (or a new encoder) on every viewer each time. Until then a
        viewer skips the frames it cannot decode (fan_out); each frame settles again. A
        paused look's frames are JPEG: nothing waits on them."""
        want = self._intersection(now)
        if want == self.session.decoders:
            return
        if now - self.key_asked >= KEY_EVERY_S:
            self.key_asked = now
            self.session.decoders = want
            self.session.need_key = True

    async def fan_out(self, frame: int, codec: str, key: bool, data: bytes, stats: dict[str, Any] | None,
                      now: float) -> None:
        """The presenter's frame (header and bytes), to every viewer with room for it."""
        self._settle_codecs(now)
        video = codec != "jpeg"
        for v in list(self.viewers.values()):
            if v.closed:
                continue
            if not v.room() or (video and (v.waiting_key and not key or codec not in v.codecs)):
                v.skipped += 1
                v.waiting_key = v.waiting_key or video   # its decoder lost the chain
                continue
            if video:
                v.waiting_key = False
            v.inflight[frame] = now
            v.last_frame = frame
            v.frames += 1
            await v.pay(now, force=True)   # the look's reply before its frame
            if stats:
                await v.send_json(stats)
            await v.send_bytes(data)
        if video and any(v.waiting_key and v.room() and codec in v.codecs for v in self.viewers.values()):
            self._ask_key(now)

    def end(self, reason: str) -> None:
        """The live session is over: each viewer is told why, then closed."""
        self.ended = True
        for v in list(self.viewers.values()):
            self.leave(v)
            v._put("text", json.dumps({"type": "ended", "msg": reason}))
            v.close(ENDED_CLOSE, reason[:120])


def new_token(room: str | None) -> str:
    """The live link's token: the room the presenter's page connected with (its load
    balancer routed it by that) and a random part (12 bytes); with no room, random."""
    return f"{room}.{secrets.token_urlsafe(12)}" if room else secrets.token_urlsafe(16)


async def presenter_message(client: "Client", parsed: Any, streamer: Any, now: float) -> bool:
    """A presenter's "share" or "control" message, or a look change while a viewer has
    control; True when handled here."""
    audience = client.audience
    if isinstance(parsed, ShareMsg):
        if parsed.active and audience is None:
            client.audience = audience = Audience(client, new_token(client.room))
            streamer.live[audience.token] = client
            log.info("session shared live", extra={"session": client.session.id})
            await audience.tell()
        elif parsed.active:
            await audience.tell()
        elif audience is not None:
            end_live(client, streamer, "the presenter stopped sharing")
            await client.send_json({"type": "audience", "role": "presenter", "token": None, "viewers": 0,
                                    "control": None, "you": None, "ids": []})
        return True
    if isinstance(parsed, ControlMsg):
        if audience is None:
            await client.send_json({"type": "error", "loc": ["message", "type"],
                                    "msg": "control is handed to a viewer of a live session: share it first"})
        elif parsed.to is not None and parsed.to not in audience.viewers:
            ids = ", ".join(audience.viewers) or "none now"
            await client.send_json({"type": "error", "loc": ["message", "to"],
                                    "msg": f"no viewer {parsed.to!r} watches this session (its viewers: {ids})"})
        else:
            audience.hand(parsed.to)
            await audience.tell()
        return True
    if audience is not None and not audience.controls(client) and isinstance(parsed, STEERING):
        if isinstance(parsed, InteractMsg):
            return True
        await client.answer_error({"type": "error", "loc": ["message", "type"],
                                   "msg": f"viewer {audience.control} has control of the look; take it back "
                                          "(Live, Take back control) to change it"},
                                  int(isinstance(parsed, LOOK_CHANGES)), now)
        return True
    return False


def presenter_left(client: "Client", streamer: Any, now: float) -> None:
    """The presenter's socket ended. With viewers watching, they wait live_resume_s for its
    page to reconnect (`resume_live`; a network blip must not end a class's session) and
    are told it is away; else, or with live_resume_s 0, the live session ends."""
    audience = client.audience
    if audience is None:
        return
    if not audience.viewers or streamer.settings.live_resume_s <= 0:
        end_live(client, streamer, "the presenter left")
        return
    client.audience = None
    audience.away_since = now
    streamer.away[audience.resume_key] = audience
    log.info("live session's presenter away", extra={"session": client.session.id})
    for v in audience.viewers.values():
        v.audience_due = True
        v._wake.set()


def resume_live(client: "Client", streamer: Any, key: str, now: float) -> bool:
    """`client`, a presenter's page reconnected with `resume=<key>` and its room, takes its
    live session back: its viewers watch its new session from here (its state, then a
    keyframe). False where there is none to take (ended, another room, another key)."""
    audience = streamer.away.get(key)
    if audience is None or client.room is None or audience.token.split(".")[0] != client.room:
        return False
    del streamer.away[key]
    audience.presenter = client
    audience.away_since = None
    client.audience = audience
    streamer.live[audience.token] = client
    state = json.dumps(client.session.state(now))
    for v in audience.viewers.values():
        v.session = client.session
        v.inflight.clear()   # the new session's frames count from 1 again
        v.last_frame = 0
        v.waiting_key = True
        v._put("text", state)
    audience._codecs()
    client.session.need_key = True
    log.info("live session resumed", extra={"session": client.session.id})
    return True


def expire_away(streamer: Any, now: float) -> None:
    """Live sessions whose presenter did not come back within live_resume_s end."""
    for key, audience in list(streamer.away.items()):
        if now - audience.away_since >= streamer.settings.live_resume_s:
            del streamer.away[key]
            if streamer.live.get(audience.token) is audience.presenter:
                del streamer.live[audience.token]
            audience.end("the presenter left")
            log.info("live session ended", extra={"session": audience.session.id, "reason": "presenter away"})


def find_audience(streamer: Any, token: str) -> "Audience | None":
    """The live session with this token: its presenter's, or one whose presenter is away."""
    client = streamer.live.get(token)
    if client is not None and client.audience is not None:
        return client.audience
    return next((a for a in streamer.away.values() if a.token == token), None)


def end_live(client: "Client", streamer: Any, reason: str) -> None:
    audience = client.audience
    if audience is None:
        return
    client.audience = None
    if streamer.live.get(audience.token) is client:
        del streamer.live[audience.token]
    client.session.decoders = None
    audience.end(reason)
    log.info("live session ended", extra={"session": client.session.id, "reason": reason})


async def viewer_endpoint(ws: WebSocket, streamer: Any, token: str, addr: str, renderer_info: dict,
                          room: str | None = None) -> None:
    """/ws?live=<token>[&room=<its room>]: one viewer of a live session. The page gives the
    token's room too, which a load balancer that cannot take a token apart hashes by
    (docker/k8s/ingress-ws.yaml); one that is not the token's is refused."""
    cfg = streamer.settings
    audience = find_audience(streamer, token) if TOKEN.fullmatch(token) else None
    refusal = None
    if "&" in token:
        refusal = (NO_SUCH_CLOSE, "live= is given more than once: a live link has one token; open the link "
                   "the presenter shared as it is")
    elif room is not None and room != token.split(".")[0]:
        refusal = (NO_SUCH_CLOSE, "room= is not this live link's room: give the part of live= before its dot, "
                   "or leave room= out")
    elif not TOKEN.fullmatch(token):
        refusal = (NO_SUCH_CLOSE, "this is not a live link: its token (live=) is the presenter's room (16-64 of "
                   "A-Z a-z 0-9 - _), a dot and 16 more; ask the presenter for the link again")
    elif audience is None:
        refusal = (NO_SUCH_CLOSE, "no live session has this link here: it has ended, or the link is not whole "
                   "(ask the presenter for it again)")
    elif len(audience.viewers) >= cfg.max_viewers:
        refusal = (1013, f"this live session has its most viewers ({cfg.max_viewers}); retry later")
    elif streamer.watching[addr] >= cfg.max_viewers_per_client:
        refusal = (1013, f"this address watches the most live sessions it may ({cfg.max_viewers_per_client} "
                   "viewers, setting max_viewers_per_client); close one and retry")
    if refusal:
        try:
            await ws.send_json({"type": "error", "loc": ["live"], "msg": refusal[1]})
            await ws.close(code=refusal[0], reason=refusal[1][:120])
        except WebSocketDisconnect:
            pass
        return
    streamer.watching[addr] += 1   # counted until this socket's handler ends, whatever ends it
    try:
        now = streamer.clock()
        session = audience.session
        viewer = Viewer(uuid.uuid4().hex[:8], session, ws, addr)
        viewer.start(audience)
        await viewer.send_json({"type": "hello", "protocol": PROTOCOL, "session": session.id,
                                "renderer": renderer_info.get("renderer"), "max_message": MAX_MESSAGE,
                                "refine_budget_ms": REFINE_BUDGET_MS, "play_budget_ms": PLAY_BUDGET_MS,
                                "live": {"role": "viewer", "id": viewer.id}})
        await viewer.send_json(session.state(now))
        audience.join(viewer, now)
        await audience.tell()
        streamer.wake()
        log.info("viewer joined", extra={"session": session.id, "viewer": viewer.id})
        from fogbank.stream.streaming import TokenBucket
        bucket = TokenBucket(cfg.messages_per_s, cfg.message_burst, now)
        try:
            while not viewer.closed:
                data = await next_message(ws)
                if data is None:
                    break
                if data is TOO_LARGE:
                    viewer.close(1009, f"message over {MAX_MESSAGE} bytes")
                    break
                now = streamer.clock()
                if not bucket.take(now):
                    metrics.ERRORS.labels("rate").inc()
                    if bucket.should_notify():
                        await viewer.send_json({"type": "error", "loc": ["message"],
                                                "msg": f"over {cfg.messages_per_s:g} messages/s: messages are "
                                                       "dropped until the rate falls"})
                    continue
                if audience.ended:   # ended meanwhile: its messages go nowhere
                    break
                session = audience.session   # its presenter's new one, when it came back
                try:
                    parsed = parse(data)
                except ProtocolError as exc:
                    await viewer.answer_error({"type": "error", "detail": exc.errors, "msg": str(exc)},
                                              refused_answers(data), now)
                    continue
                if isinstance(parsed, AckMsg):
                    viewer.ack(parsed.frame, now)
                    await viewer.pay(now)
                elif isinstance(parsed, PongMsg):
                    pass
                elif isinstance(parsed, ViewMsg):   # its codecs; the size is the presenter's
                    audience.set_codecs(viewer, tuple(parsed.codecs), now)
                    streamer.wake()
                elif isinstance(parsed, ShareMsg):
                    await viewer.send_json({"type": "error", "loc": ["message", "type"],
                                            "msg": "only the presenter shares a live session"})
                elif isinstance(parsed, ControlMsg):
                    if parsed.to is None and audience.control == viewer.id:   # handed back
                        audience.hand(None)
                        await audience.tell()
                    else:
                        await viewer.send_json({"type": "error", "loc": ["message", "type"],
                                                "msg": "only the presenter hands control over; a viewer with "
                                                       "control may give it back (to: null)"})
                elif audience.away_since is not None and isinstance(parsed, STEERING):
                    await viewer.answer_error({"type": "error", "loc": ["message", "type"],
                                               "msg": "the presenter's connection dropped: the look waits for it to "
                                                      "come back (a few seconds)"},
                                              int(isinstance(parsed, LOOK_CHANGES)), now)
                elif audience.controls(viewer):
                    await apply_change(session, parsed, viewer, audience.others(viewer), now)
                    streamer.wake()
                elif isinstance(parsed, InteractMsg):
                    pass
                else:
                    await viewer.answer_error({"type": "error", "loc": ["message", "type"],
                                               "msg": "you are watching a live session: the presenter has control "
                                                      "of the look (open it on your own with Copy link)"},
                                              int(isinstance(parsed, LOOK_CHANGES)), now)
        except WebSocketDisconnect:
            pass
        finally:
            if audience.leave(viewer, streamer.clock()):
                await audience.tell()
            log.info("viewer left", extra={"session": session.id, "viewer": viewer.id, "frames": viewer.frames,
                                           "skipped": viewer.skipped})
            if viewer._close is None:
                viewer.close(1000, "")
            if viewer._task is not None:   # what it has queued goes out, then its socket closes
                try:
                    await asyncio.wait_for(asyncio.shield(viewer._task), 2.0)
                except (asyncio.TimeoutError, Exception):  # noqa: BLE001
                    await viewer.stop()
    finally:
        streamer.watching[addr] -= 1
        if streamer.watching[addr] <= 0:
            del streamer.watching[addr]
