"""Request limits enforced before anything is parsed: body size (413), request-target
length (414), header count and size (431). Pure ASGI, so the body is counted as it
arrives and never buffered past the limit; every refusal is JSON naming the limit.

The HTTP server (uvicorn on h11, see cli.py) bounds what it buffers for a request head
to `MAX_HEAD_BYTES`; below that, these checks answer in JSON.
"""

from __future__ import annotations

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from fogbank.model import errors

MAX_HEAD_BYTES = 1 << 20   # h11's buffer for a request line and headers


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
        target = len(scope.get("raw_path") or scope["path"].encode()) + len(scope.get("query_string", b""))
        problem = None
        if target > self.max_url:
            problem = (414, "url", f"the request target is {target} bytes; at most {self.max_url} are "
                                   "allowed (for long looks, POST /api/still with a JSON body)")
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


def json_h11_protocol():
    """uvicorn's h11 protocol, answering requests it cannot parse (a request head over
    MAX_HEAD_BYTES, malformed HTTP) in JSON like every other error, not plain text."""
    import h11
    from uvicorn.protocols.http.h11_impl import H11Protocol

    class JSONErrorsH11(H11Protocol):
        def send_400_response(self, msg: str) -> None:
            body = errors.body_bytes([errors.error(
                ["request"], f"the request is malformed, or its line and headers exceed "
                f"{MAX_HEAD_BYTES} bytes", "bad_request")])
            event = h11.Response(status_code=400, reason=b"Bad Request",
                                 headers=[(b"content-type", b"application/json"), (b"connection", b"close")])
            for ev in (event, h11.Data(data=body), h11.EndOfMessage()):
                self.transport.write(self.conn.send(ev))
            self.transport.close()
    return JSONErrorsH11
