"""Processes the tests start on 127.0.0.1: fogbank servers and nginx, each stopped by the
PID it was started with."""

from __future__ import annotations

import asyncio
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
from pathlib import Path

import websockets

from fogbank.tools.link import run_in_thread

DOCKER = Path(__file__).resolve().parents[1] / "docker"


# asyncio.run in a thread of its own: Playwright's sync API keeps a loop running in the
# test thread once a browser is up (the link tools need the same)
run_async = run_in_thread


HEAVY = {"width": 1920, "height": 1080, "layers": [{"kind": "noise", "mode": "volume", "samples": 128}]}


def post_still(url: str, body: dict, timeout: float = 120):
    """POST /api/still?format=png; (status, headers, body) whatever the status."""
    req = urllib.request.Request(url + "/api/still?format=png", data=json.dumps(body).encode(),
                                 headers={"Content-Type": "application/json"})
    try:
        with urllib.request.urlopen(req, timeout=timeout) as r:
            return r.status, r.headers, r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.headers, e.read()


async def watch_stream(url: str, seconds: float, size=(320, 180), query: str = "v=1&time=3",
                       resize=None) -> int:
    """Open /ws, ask for `size`, acknowledge every frame for `seconds`; returns how many
    frames came. `resize(n)` may return a new (width, height) after frame n."""
    async with websockets.connect(url.replace("http", "ws", 1) + "/ws?" + query) as ws:
        await ws.recv(), await ws.recv()
        await ws.send(json.dumps({"type": "view", "width": size[0], "height": size[1], "fps": 30}))
        n, t0 = 0, time.monotonic()
        while time.monotonic() - t0 < seconds:
            try:
                m = await asyncio.wait_for(ws.recv(), 1.0)
            except asyncio.TimeoutError:
                continue
            if isinstance(m, bytes):
                n += 1
                await ws.send(json.dumps({"type": "ack", "frame": int.from_bytes(m[4:8], "little")}))
                new = resize(n) if resize else None
                if new:
                    await ws.send(json.dumps({"type": "view", "width": new[0], "height": new[1]}))
        return n


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_http(url: str, timeout: float = 60) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            with urllib.request.urlopen(url, timeout=2) as r:
                if r.status == 200:
                    return
        except OSError:
            time.sleep(0.2)
    raise RuntimeError(f"{url} did not answer")


class Server:
    """A fogbank server process on 127.0.0.1."""

    def __init__(self, port: int | None = None, env: dict | None = None):
        self.port = port or free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.env = env or {}
        self.proc: subprocess.Popen | None = None
        self.log = tempfile.NamedTemporaryFile(prefix="fogbank-", suffix=".log", delete=False)

    def start(self) -> "Server":
        self.proc = subprocess.Popen([sys.executable, "-m", "fogbank.cli", "serve", "--host", "127.0.0.1",
                                      "--port", str(self.port)], env={**os.environ, **self.env},
                                     stdout=self.log, stderr=subprocess.STDOUT)
        wait_http(self.url + "/healthz")
        return self

    def stop(self, sig=signal.SIGTERM, timeout: float = 30) -> float:
        """Signal the process by its PID; returns how long it took to exit."""
        if not self.proc or self.proc.poll() is not None:
            return 0.0
        t0 = time.monotonic()
        os.kill(self.proc.pid, sig)
        try:
            self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            os.kill(self.proc.pid, signal.SIGKILL)
            self.proc.wait(10)
        return time.monotonic() - t0

    def logs(self) -> str:
        return Path(self.log.name).read_text(errors="replace")


def ingress_http(servers: str) -> str:
    """docker/k8s's ingresses as ingress-nginx routes them, in plain nginx: an upstream per
    service (`servers` are the pods), hashed by its ingress's `upstream-hash-by` where it
    has one (ingress-nginx's balancer hashes consistently; nginx's plain `hash` routes by
    the same key), a location per path (Exact: `=`), WebSockets passed through. Only what
    routes is built: no timeouts, buffers or retries."""
    import yaml
    ups, locs = {}, []
    for path in sorted((DOCKER / "k8s").glob("ingress*.yaml")):
        ing = yaml.safe_load(path.read_text())
        key = ing["metadata"].get("annotations", {}).get("nginx.ingress.kubernetes.io/upstream-hash-by")
        for rule in ing["spec"]["rules"]:
            for p in rule["http"]["paths"]:
                svc = p["backend"]["service"]["name"].replace("-", "_")
                ups[svc] = f"        hash {key};\n" if key else ""
                exact = "= " if p["pathType"] == "Exact" else ""
                locs.append(f"""
    location {exact}{p["path"]} {{
        proxy_pass http://{svc};
        proxy_http_version 1.1;
        proxy_set_header Upgrade $http_upgrade;
        proxy_set_header Connection "upgrade";
        proxy_set_header Host $host;
    }}""")
    return "".join(f"""
    upstream {name} {{
{hashed}{servers}
    }}""" for name, hashed in ups.items()) + f"""
    server {{
        include listen.conf;{"".join(locs)}
    }}"""


class Nginx:
    """Debian's nginx with docker/nginx/fogbank.conf in front of `upstreams`, every path
    (pid, logs, temp) inside a temp dir."""

    def __init__(self, upstreams: list[int], read_timeout_s: int | None = None, ingress: bool = False):
        """`read_timeout_s`: the config's proxy_read_timeout values replaced by this (a
        test of failover need not wait the 65 s the app's longest answer needs).
        `ingress`: instead of fogbank.conf, the Kubernetes ingresses' routing (ingress_http).
        Without `ingress`, the access log gives each request's $request_uri and the key the
        upstream is hashed by ($fogbank_route), tab-separated (routes())."""
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.dir = Path(tempfile.mkdtemp(prefix="fogbank-nginx-"))
        servers = "\n".join(f"        server 127.0.0.1:{p} max_fails=3 fail_timeout=5s;" for p in upstreams)
        d = self.dir
        conf = DOCKER / "nginx" / "fogbank.conf"
        if read_timeout_s is not None:
            text = conf.read_text()
            assert "proxy_read_timeout 65s;" in text
            conf = d / "fogbank.conf"
            conf.write_text(text.replace("proxy_read_timeout 65s;", f"proxy_read_timeout {read_timeout_s}s;"))
        (d / "listen.conf").write_text(f"listen 127.0.0.1:{self.port};\n")
        body = ingress_http(servers) if ingress else (
            f"    upstream fogbank {{\n        hash $fogbank_route;\n{servers}\n    }}\n    include {conf};")
        log = (f"    access_log {d}/access.log;" if ingress else
               f"    log_format route '$request_uri\\t$fogbank_route';\n    access_log {d}/access.log route;")
        (d / "nginx.conf").write_text(f"""
daemon off;
worker_processes 1;
pid {d}/nginx.pid;
error_log {d}/error.log warn;
events {{ worker_connections 1024; }}
http {{
    client_body_temp_path {d}/client_body;
    proxy_temp_path {d}/proxy;
    fastcgi_temp_path {d}/fastcgi;
    uwsgi_temp_path {d}/uwsgi;
    scgi_temp_path {d}/scgi;
{body}
{log}
}}
""")
        self.proc: subprocess.Popen | None = None

    def routes(self) -> list[tuple[str, str]]:
        """(request URI, hash key) of each request logged so far."""
        lines = (self.dir / "access.log").read_text().splitlines()
        return [tuple(line.split("\t")) for line in lines]   # type: ignore[misc]

    def start(self) -> "Nginx":
        self.proc = subprocess.Popen(["nginx", "-p", str(self.dir), "-c", str(self.dir / "nginx.conf")],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wait_http(self.url + "/healthz")
        return self

    def stop(self) -> None:
        if self.proc and self.proc.poll() is None:
            os.kill(self.proc.pid, signal.SIGTERM)
            self.proc.wait(20)
