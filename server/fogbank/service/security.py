"""Web hardening: the page's Content-Security-Policy and the WebSocket Origin check."""

from __future__ import annotations

import ipaddress
from urllib.parse import urlsplit

from starlette.datastructures import Headers
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from fogbank.model import errors

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


# probes and scrapers address a replica by its own address (a Kubernetes probe sends the
# pod's IP as its Host): these also answer a Host that is an IP address. A rebinding page
# needs a name of its own, never an address, so they still refuse other names
PROBE_PATHS = frozenset({"/healthz", "/readyz", "/metrics"})


def allowed_hosts(listed: str, bind_host: str) -> frozenset[str]:
    """The host names this server answers to: the comma-separated list, and the address
    it binds unless that is every address."""
    hosts = {h.strip().lower().strip("[]") for h in listed.split(",") if h.strip()}
    if bind_host not in ("", "0.0.0.0", "::"):
        hosts.add(bind_host.lower().strip("[]"))
    return frozenset(hosts)


def host_allowed(host: str | None, allowed: frozenset[str], address_too: bool = False) -> bool:
    """Whether `host` (a Host header) names one of `allowed`; with `address_too`, any IP
    address, or no Host at all, passes as well (PROBE_PATHS)."""
    if "*" in allowed:
        return True
    if not host:   # an HTTP/1.0 health check may send none; a browser always sends one
        return address_too
    try:
        name = urlsplit("//" + host).hostname   # "[::1]:8000" -> "::1"
    except ValueError:
        return False
    if name is None:
        return False
    if name.lower() in allowed:
        return True
    try:
        return address_too and bool(ipaddress.ip_address(name))
    except ValueError:
        return False


def client_key(host: str) -> str:
    """What per-client caps count by: an IPv4 address as it is, an IPv6 one as its /64 (one
    subscriber's network: a host is handed a whole /64 and may use any address in it, so
    per-address caps would not hold it), an IPv4-mapped IPv6 address as its IPv4 one; any
    other name (a test client's) as it is."""
    try:
        ip = ipaddress.ip_address(host)
    except ValueError:
        return host
    if ip.version == 6:
        if ip.ipv4_mapped is not None:
            return str(ip.ipv4_mapped)
        return str(ipaddress.ip_network(f"{ip}/64", strict=False))
    return str(ip)


class HostCheck:
    """DNS rebinding guard (pure ASGI): a page of another site whose name was made to
    resolve to this server sends its own name as Host, and Origin matches it, so the
    Origin check passes (issue 33: Host and Origin evil.com:8051 got 101). Requests whose
    Host is not one of the allowed names get a JSON 400 naming it; a WebSocket is refused
    (403) before it opens."""

    def __init__(self, app: ASGIApp, allowed: frozenset[str]):
        self.app = app
        self.allowed = allowed

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        host = Headers(scope=scope).get("host")
        if host_allowed(host, self.allowed, address_too=scope.get("path") in PROBE_PATHS):
            await self.app(scope, receive, send)
            return
        if scope["type"] == "websocket":
            await send({"type": "websocket.close", "code": 1008, "reason": "host not allowed"})
            return
        body = errors.body_bytes([errors.error(
            ["header", "host"], f"this server does not answer to the host {host!r}; it answers to "
            f"{', '.join(sorted(self.allowed))} (FOGBANK_ALLOWED_HOSTS)", "host")])
        await send({"type": "http.response.start", "status": 400,
                    "headers": [(b"content-type", b"application/json"),
                                (b"content-length", str(len(body)).encode())]})
        await send({"type": "http.response.body", "body": body})
