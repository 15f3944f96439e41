"""Web hardening: the page's Content-Security-Policy and the WebSocket Origin check."""

from __future__ import annotations

from urllib.parse import urlsplit

from starlette.types import ASGIApp, Message, Receive, Scope, Send

# connect-src 'self' covers the page's own WebSocket (CSP Level 3 matches ws:/wss: to the
# page's host and port under 'self'); "ws: wss:" let a script talk to any host
CSP = ("default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' blob: data:; "
       "connect-src 'self'; object-src 'none'; base-uri 'none'; frame-ancestors 'none'; "
       "form-action 'self'")
HEADERS = [(b"content-security-policy", CSP.encode()), (b"x-content-type-options", b"nosniff"),
           (b"referrer-policy", b"same-origin"), (b"x-frame-options", b"DENY")]


class SecurityHeaders:
    """Adds the CSP and friends to every HTTP response (pure ASGI: streams untouched)."""

    def __init__(self, app: ASGIApp):
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return

        async def send_with_headers(message: Message) -> None:
            if message["type"] == "http.response.start":
                message.setdefault("headers", [])
                message["headers"] = list(message["headers"]) + HEADERS
            await send(message)
        await self.app(scope, receive, send_with_headers)


def _origin_tuple(scheme: str, netloc: str) -> tuple[str, str, int] | None:
    """(scheme, host, port) with the scheme's default port filled in."""
    scheme = scheme.lower()
    default = {"http": 80, "https": 443}.get(scheme)
    if default is None:
        return None
    try:
        parts = urlsplit(f"{scheme}://{netloc}")
        port = parts.port or default
    except ValueError:
        return None
    return scheme, (parts.hostname or "").lower(), port


def origin_allowed(origin: str | None, host: str | None, allowed: str, scheme: str = "ws") -> bool:
    """Cross-site WebSocket hijacking guard: a browser always sends Origin; it must be
    this server's own origin (scheme, host and port: a page served over https connects
    with wss) or in the allow-list. Clients that send no Origin (not a browser) are let
    through: they carry no victim's cookies."""
    if origin is None:
        return True
    allow = {o.strip().rstrip("/") for o in allowed.split(",") if o.strip()}
    if "*" in allow or origin.rstrip("/") in allow:
        return True
    parts = urlsplit(origin)
    theirs = _origin_tuple(parts.scheme, parts.netloc)
    ours = _origin_tuple("https" if scheme in ("wss", "https") else "http", host or "")
    return bool(host) and theirs is not None and theirs == ours
