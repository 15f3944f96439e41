"""Request limits enforced before anything is parsed: body size (413), request-target
length (414), header count and size (431). Pure ASGI, so the body is counted as it
arrives and never buffered past the limit; every refusal is JSON naming the limit, but
for an over-long link opened in a browser: a page that says how long it is, the limit,
and that the page's "Copy link" makes compact links that fit (414).

The HTTP server (uvicorn on h11, see cli.py) bounds what it buffers for a request head
to `MAX_HEAD_BYTES`; below that, these checks answer. Past it, a request line is answered
with the same 414 (its length unknown: more than MAX_HEAD_BYTES), anything else in JSON.
"""

from __future__ import annotations

import asyncio

import base64
import hashlib
import re

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from fogbank.model import errors
from fogbank.model.urlstate import MAX_COMPACT

MAX_HEAD_BYTES = 1 << 20   # h11's buffer for a request line and headers
# The service's machine routes: their errors are JSON, over-long URLs included. Every
# other GET (the page, its docs, static files) is what a browser opens: an HTML page.
MACHINE_ROUTES = ("/api/", "/healthz", "/readyz", "/metrics", "/openapi.json")

_STYLE = ("body{font:16px/1.5 system-ui,sans-serif;max-width:40em;margin:4em auto;padding:0 1em;"
          "color:#1d232b;background:#f4f6f8}h1{font-size:1.5em}code{font-size:.9em}")
# no script, no images: the inline style alone, allowed by its hash
PAGE_HEADERS = [
    (b"content-type", b"text/html; charset=utf-8"),
    (b"content-security-policy", (
        "default-src 'none'; style-src 'sha256-"
        + base64.b64encode(hashlib.sha256(_STYLE.encode()).digest()).decode()
        + "'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'").encode()),
    (b"x-content-type-options", b"nosniff"), (b"referrer-policy", b"same-origin"),
]


def wants_page(method: str, path: str) -> bool:
    """Whether a refusal of this request is a page (a browser opened a link) or JSON."""
    return method in ("GET", "HEAD") and not path.startswith(MACHINE_ROUTES)


def too_long_page(length: int | None, limit: int) -> bytes:
    """The page for a link longer than `limit` characters (`length`; None: more than
    MAX_HEAD_BYTES, the most the server reads of a request head)."""
    size = f"{length:,} characters long" if length is not None else f"more than {MAX_HEAD_BYTES:,} characters long"
    return f"""<!doctype html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>Link too long - fogbank</title>
<style>{_STYLE}</style>
</head>
<body>
<main>
<h1>This link is too long</h1>
<p id="length">It is {size}; this server takes links of at most {limit:,} characters.</p>
<p>A look with many layers makes a long readable link. Every look also has a compact
link, with the whole look compressed into it (<code>z=&hellip;</code>) in at most
{MAX_COMPACT:,} characters: open the look on the page and press <strong>Copy link</strong>,
which copies the compact link whenever the readable one is long.</p>
<p>If this link was sent to you, ask for the link that <strong>Copy link</strong> gives.</p>
<p><a href="/">Open fogbank</a></p>
</main>
</body>
</html>
""".encode()


async def _refuse_page(send: Send, status: int, body: bytes) -> None:
    await send({"type": "http.response.start", "status": status,
                "headers": PAGE_HEADERS + [(b"content-length", str(len(body)).encode()),
                                           (b"connection", b"close")]})
    await send({"type": "http.response.body", "body": body})


async def _refuse(send: Send, status: int, loc: str, msg: str) -> None:
    body = errors.body_bytes([errors.error([loc], msg, "too_large")])
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode()),
                            (b"connection", b"close")]})
    await send({"type": "http.response.body", "body": body})


class RequestLimits:
    def __init__(self, app: ASGIApp, max_body: int, max_url: int, max_headers: int, max_header_bytes: int):
        self.app = app
        self.max_body, self.max_url = max_body, max_url
        self.max_headers, self.max_header_bytes = max_headers, max_header_bytes

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        headers = scope.get("headers", [])
        query = scope.get("query_string", b"")
        target = len(scope.get("raw_path") or scope["path"].encode()) + (len(query) + 1 if query else 0)
        problem = None
        if target > self.max_url and scope["type"] == "http" and wants_page(scope["method"], scope["path"]):
            await _refuse_page(send, 414, too_long_page(target, self.max_url))
            return
        if target > self.max_url:
            problem = (414, "url", f"the request target is {target} bytes; at most {self.max_url} are "
                                   "allowed (for long looks, the compact query z=... that the page's "
                                   "Copy link makes, or POST /api/still with a JSON body)")
        elif len(headers) > self.max_headers:
            problem = (431, "headers", f"{len(headers)} headers; at most {self.max_headers} are allowed")
        elif sum(len(k) + len(v) + 4 for k, v in headers) > self.max_header_bytes:
            problem = (431, "headers", f"the headers exceed {self.max_header_bytes} bytes")
        if problem:
            if scope["type"] == "websocket":
                await send({"type": "websocket.close", "code": 1009, "reason": problem[2][:120]})
                return
            await _refuse(send, *problem)
            return
        if scope["type"] == "websocket":
            await self.app(scope, receive, send)
            return
        for k, v in headers:
            if k == b"content-length":
                try:
                    n = int(v)
                except ValueError:
                    await _refuse(send, 400, "content-length", "Content-Length is not an integer")
                    return
                if n > self.max_body:
                    await _refuse(send, 413, "body", f"the body is {n} bytes; at most {self.max_body} are allowed")
                    return
        # read the body here, counting as it arrives; the app gets it replayed
        chunks, received = [], 0
        while True:
            msg = await receive()
            if msg["type"] != "http.request":   # the client went away
                return
            chunk = msg.get("body", b"")
            received += len(chunk)
            if received > self.max_body:
                await _refuse(send, 413, "body", f"the body exceeds {self.max_body} bytes")
                return
            chunks.append(chunk)
            if not msg.get("more_body", False):
                break
        body = b"".join(chunks)
        replayed = False

        async def replay() -> Message:
            nonlocal replayed
            if not replayed:
                replayed = True
                return {"type": "http.request", "body": body, "more_body": False}
            return await receive()

        await self.app(scope, replay, send)


_REQUEST_LINE = re.compile(rb"([A-Z]{1,16}) (/[^?\s]*)")


def json_h11_protocol(max_url: int, head_timeout_s: float = 10.0, body_timeout_s: float = 30.0):
    """uvicorn's h11 protocol, answering requests it cannot parse (a request head over
    MAX_HEAD_BYTES, malformed HTTP) in JSON like every other error, not plain text; a
    request line over MAX_HEAD_BYTES is a 414, a page where a browser opened it. `max_url`
    is the app's own limit (RequestLimits), which the answer names.

    It also times the reading of a request (uvicorn does not): its head must arrive within
    `head_timeout_s` of the connection (or of the last response on it) and its body within
    `body_timeout_s` of the head, else the client gets a JSON 408 and the connection is
    closed. 20 sockets that sent a header line every few seconds held their connections
    for as long as they liked (issue 33)."""
    import h11
    from uvicorn.protocols.http.h11_impl import H11Protocol

    class JSONErrorsH11(H11Protocol):
        _read_timer: asyncio.TimerHandle | None = None
        _reading: str | None = None   # "head" or "body": what the running timer waits for

        def _arm(self, what: str, seconds: float) -> None:
            self._disarm()
            self._reading = what
            self._read_timer = self.loop.call_later(seconds, self._read_timeout)

        def _disarm(self) -> None:
            if self._read_timer is not None:
                self._read_timer.cancel()
            self._read_timer, self._reading = None, None

        def connection_made(self, transport) -> None:  # type: ignore[override]
            super().connection_made(transport)
            self._arm("head", head_timeout_s)

        def connection_lost(self, exc) -> None:
            self._disarm()
            super().connection_lost(exc)

        def _follow(self) -> None:
            """The timer for what the connection reads now: a head (idle), a body, or none
            (a request read, or the protocol switched); a running one is kept."""
            state = self.conn.their_state
            if state is h11.IDLE:
                if self._reading != "head":
                    self._arm("head", head_timeout_s)
            elif state is h11.SEND_BODY:
                if self._reading != "body":
                    self._arm("body", body_timeout_s)
            else:
                self._disarm()

        def handle_events(self) -> None:
            super().handle_events()
            self._follow()

        def on_response_complete(self) -> None:
            # uvicorn starts the next cycle here, and reads a pipelined request already
            # received: its head may be read and its body due (a head timer armed over the
            # body's cut it to head_timeout_s and named the wrong part)
            self._disarm()
            super().on_response_complete()
            self._follow()

        def _read_timeout(self) -> None:
            what, seconds = self._reading, head_timeout_s if self._reading == "head" else body_timeout_s
            self._read_timer, self._reading = None, None
            if self.transport.is_closing() or self.transport.get_protocol() is not self:
                return   # closed, or upgraded to a WebSocket
            if self.conn.their_state not in (h11.IDLE, h11.SEND_BODY):
                return
            if self.conn.their_state is h11.IDLE and not self.conn.trailing_data[0]:
                self.transport.close()   # nothing of a request came: closed as an idle connection is
                return
            if self.cycle is not None and self.cycle.response_started:
                self.transport.close()
                return
            body = errors.body_bytes([errors.error(
                ["request"], f"the request's {what} did not arrive within {seconds:g} s", "timeout")])
            self.transport.write(b"HTTP/1.1 408 Request Timeout\r\ncontent-type: application/json\r\n"
                                 b"content-length: " + str(len(body)).encode() + b"\r\nconnection: close\r\n\r\n"
                                 + body)
            self.transport.close()

        def send_400_response(self, msg: str) -> None:
            # what h11 could not make a request of: an over-long request line has no line
            # end in it yet
            buf = self.conn.trailing_data[0]
            line = _REQUEST_LINE.match(buf[:4096])
            status, reason = 400, b"Bad Request"
            headers = [(b"content-type", b"application/json")]
            body = errors.body_bytes([errors.error(
                ["request"], f"the request is malformed, or its line and headers exceed "
                f"{MAX_HEAD_BYTES} bytes", "bad_request")])
            if len(buf) > MAX_HEAD_BYTES and line is not None and b"\n" not in buf:
                status, reason = 414, b"URI Too Long"
                if wants_page(line[1].decode(), line[2].decode("latin-1")):
                    headers, body = PAGE_HEADERS, too_long_page(None, max_url)
                else:
                    body = errors.body_bytes([errors.error(
                        ["url"], f"the request target is more than {MAX_HEAD_BYTES} bytes; at most "
                        f"{max_url} are allowed", "too_large")])
            event = h11.Response(status_code=status, reason=reason, headers=[
                *headers, (b"content-length", str(len(body)).encode()), (b"connection", b"close")])
            for ev in (event, h11.Data(data=body), h11.EndOfMessage()):
                self.transport.write(self.conn.send(ev))
            self.transport.close()
    return JSONErrorsH11
