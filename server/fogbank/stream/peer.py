"""One socket of a session, as the server writes to it: its messages, and the reply it
owes to look changes, which waits in the flow-control window (issue 34).

A reply to look changes goes out only while fewer than the socket's window of frames are
unacknowledged on it (Peer.window), or just before a frame; changes made meanwhile collapse
into one reply, built from the session as it is when it goes. Its "answers" counts the
changes it answers (made on this socket: a live session's other sockets are told of a
change with answers 0). The presenter's socket is a streaming.Client, a viewer's a
live.Viewer: each counts its own frames in flight."""

from __future__ import annotations

import asyncio
import json
from typing import Any

from starlette.websockets import WebSocket

from fogbank.stream.protocol import (MAX_MESSAGE, CameraMsg, InteractMsg, ParamsMsg, PlayMsg, QueryMsg, SeekMsg,
                                     SpeedMsg)
from fogbank.stream.session import MAX_IN_FLIGHT, Session

# replies that wait for room in the window and collapse (Peer.owe), and the messages that
# change the look, each counted in the reply's "answers"
OWED = ("state", "camera")
LOOK_CHANGES = (QueryMsg, ParamsMsg, CameraMsg, SeekMsg)
LOOK_CHANGE_TYPES = {"query", "params", "camera", "seek"}


def refused_answers(data: str | bytes) -> int:
    """What the error for a message the protocol refused answers: 1 when its "type" is a
    look change (the page counts its changes' answers), else 0."""
    try:
        msg = json.loads(data)
    except (ValueError, RecursionError, UnicodeDecodeError):
        return 0
    kind = msg.get("type") if isinstance(msg, dict) else None   # a list or an object is no type
    return int(isinstance(kind, str) and kind in LOOK_CHANGE_TYPES)
# the messages that steer the session: only whoever has control sends them (stream/live.py)
STEERING = (*LOOK_CHANGES, PlayMsg, SpeedMsg, InteractMsg)


class Peer:
    def __init__(self, session: Session, ws: WebSocket):
        self.session = session
        self.ws = ws
        self.send_lock = asyncio.Lock()
        self.closed = False
        self.owed: str | None = None   # "camera" or "state" (a "state" covers a camera)
        self.owed_answers = 0

    def unacked(self) -> int:
        """Frames sent on this socket and not acknowledged."""
        raise NotImplementedError

    def window(self) -> int:
        """Frames that may be unacknowledged on this socket before a reply waits."""
        return MAX_IN_FLIGHT

    def owe(self, kind: str, answers: int) -> None:
        self.owed = "state" if "state" in (kind, self.owed) else kind
        self.owed_answers += answers

    async def pay(self, now: float, force: bool = False) -> None:
        """Send the owed reply if fewer than window() frames are unacknowledged (or `force`:
        a frame follows it)."""
        if self.owed is None or (not force and self.unacked() >= self.window()):
            return
        s = self.session
        msg = s.state(now) if self.owed == "state" else s.camera_state()
        msg["answers"] = self.owed_answers
        self.owed, self.owed_answers = None, 0
        await self.send_json(msg)

    async def answer_error(self, msg: dict[str, Any], answers: int, now: float) -> None:
        """An error; one that answers a look change (`answers` 1) goes after the replies
        owed to the changes before it, so that the client reads its answers in order."""
        if answers:
            await self.pay(now, force=True)
        await self.send_json({**msg, "answers": answers})

    async def send_json(self, msg: dict[str, Any]) -> None:
        # ASCII JSON: user text echoed in an error (a field name, a value) may hold lone
        # surrogates, which cannot be encoded as UTF-8 and took the socket down
        text = json.dumps(msg)
        async with self.send_lock:
            await self.ws.send_text(text)

    async def send_bytes(self, data: bytes) -> None:
        async with self.send_lock:
            await self.ws.send_bytes(data)


async def apply_change(session: Session, msg: Any, by: Peer, others: list[Peer], now: float) -> None:
    """Apply a message of `by`'s to the session: its reply is owed to `by` (answering it)
    and to `others` (a live session's other sockets, answering nothing of theirs); an error
    goes to `by` alone. Each reply goes now if its socket's window has room."""
    answers = int(isinstance(msg, LOOK_CHANGES))
    for out in session.apply(msg, now):
        if out["type"] in OWED:
            by.owe(out["type"], answers)
            for p in others:
                p.owe(out["type"], 0)
        else:
            await by.answer_error(out, answers, now)
    await by.pay(now)
    for p in others:
        await p.pay(now)


TOO_LARGE = object()   # next_message's answer for a message over MAX_MESSAGE


async def next_message(ws: WebSocket) -> str | bytes | object | None:
    """A socket's next message, text or bytes; None once the client has left, TOO_LARGE
    for one over MAX_MESSAGE (the caller closes the socket with 1009)."""
    msg = await ws.receive()
    if msg["type"] == "websocket.disconnect":
        return None
    data = msg.get("text")
    if data is None:
        data = msg.get("bytes") or b""
    size = len(data.encode("utf-8")) if isinstance(data, str) else len(data)
    return TOO_LARGE if size > MAX_MESSAGE else data
