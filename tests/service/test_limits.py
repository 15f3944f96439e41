"""Limits and abuse: session cap (1013), message rate, concurrent stills (503 +
Retry-After), render timeout, Origin check, CSP, static confinement, metrics."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request

import pytest
from fastapi.testclient import TestClient
from starlette.websockets import WebSocketDisconnect

from fogbank.service.api import create_app
from fogbank.settings import Settings


@pytest.fixture(scope="module")
def limited():
    app = create_app(Settings(max_sessions=1, messages_per_s=5, message_burst=3,
                              allowed_origins="https://fog.example"))
    with TestClient(app) as c:
        yield c


def test_session_cap_refuses_with_1013(limited):
    with limited.websocket_connect("/ws") as a:
        a.receive_json()
        with limited.websocket_connect("/ws") as b:
            msg = b.receive_json()
            assert msg["type"] == "error" and msg["retry_after"] == 5 and "full" in msg["msg"]
            m = b.receive()
            assert m["type"] == "websocket.close" and m["code"] == 1013


def test_message_rate_limit_tells_once_then_drops_silently(limited):
    """A flood gets one notice per overflow, not one reply per dropped message (a
    5000-message flood drew 4735 replies)."""
    with limited.websocket_connect("/ws") as ws:
        ws.receive_json(), ws.receive_json()
        for _ in range(40):
            ws.send_json({"type": "speed", "speed": 1.0})
        time.sleep(1.0)                                  # the bucket refills (5/s)
        ws.send_json({"type": "speed", "speed": 2.5})    # a marker that passes
        texts = []
        while not (texts and texts[-1].get("type") == "state" and texts[-1]["speed"] == 2.5):
            m = ws.receive()
            if m.get("text"):
                texts.append(json.loads(m["text"]))
            elif m.get("bytes"):
                ws.send_json({"type": "ack", "frame": int.from_bytes(m["bytes"][4:8], "little")})
        dropped = [t for t in texts if t["type"] == "error" and "messages/s" in t["msg"]]
        states = [t for t in texts if t["type"] == "state"]
        assert len(dropped) == 1
        assert 3 <= len(states) <= 8    # the burst of 3 (plus refill while sending) and the marker


@pytest.mark.parametrize("origin,ok", [("https://evil.example", False), ("https://fog.example", True),
                                       ("http://testserver", True)])
def test_websocket_origin_check(limited, origin, ok):
    if ok:
        with limited.websocket_connect("/ws", headers={"origin": origin}) as ws:
            assert ws.receive_json()["type"] == "hello"
    else:
        with pytest.raises(WebSocketDisconnect) as exc:
            with limited.websocket_connect("/ws", headers={"origin": origin}) as ws:
                ws.receive_json()
        assert exc.value.code == 1008


def test_csp_and_static_confinement(client):
    r = client.get("/")
    assert "script-src 'self'" in r.headers["content-security-policy"]
    assert r.headers["x-content-type-options"] == "nosniff"
    assert "<script" in r.text and "<script>" not in r.text    # no inline script
    for path in ("/static/../server/fogbank/api.py", "/static/%2e%2e/pyproject.toml",
                 "/static/..%2fpyproject.toml", "/static//etc/passwd"):
        assert client.get(path).status_code == 404


def test_render_timeout_is_a_503():
    with TestClient(create_app(Settings(render_timeout_s=0.05))) as c:
        r = c.get("/api/still.png?width=1920&height=1080&time=3")
        assert r.status_code == 503
        assert r.headers["retry-after"] == "5"
        assert "took over 0.05 s" in r.json()["detail"]


def test_metrics(client):
    with client.websocket_connect("/ws") as ws:
        ws.receive_json(), ws.receive_json()
        ws.send_json({"type": "view", "width": 64, "height": 64})
        while not ws.receive().get("bytes"):
            pass
    client.get("/api/still.jpg?width=32&height=32&time=1")
    text = client.get("/metrics").text
    for name in ("fogbank_frames_total", "fogbank_stills_total", "fogbank_render_ms_bucket",
                 "fogbank_encode_ms_bucket", "fogbank_sessions", "fogbank_render_queue", "fogbank_errors_total"):
        assert name in text
    assert 'fogbank_stills_total{format="jpg"}' in text


def test_concurrent_stills_beyond_the_cap_get_503():
    """A real server with FOGBANK_MAX_STILLS=1 and FOGBANK_MAX_QUEUED_STILLS=1: of four
    simultaneous big stills, one renders, one waits for it, and the ones that find both
    places taken get 503 with Retry-After; none fail otherwise."""
    import socket
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    env = {**os.environ, "FOGBANK_MAX_STILLS": "1", "FOGBANK_MAX_QUEUED_STILLS": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "fogbank.cli", "serve", "--port", str(port)],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        base = f"http://127.0.0.1:{port}"
        for _ in range(300):
            try:
                urllib.request.urlopen(base + "/healthz", timeout=1)
                break
            except OSError:
                time.sleep(0.2)
        codes, retry = [], []

        def get(i):
            try:
                with urllib.request.urlopen(f"{base}/api/still.png?width=1920&height=1080&time={i}",
                                            timeout=120) as r:
                    codes.append(r.status)
            except urllib.error.HTTPError as e:
                codes.append(e.code)
                retry.append(e.headers.get("Retry-After"))
        threads = [threading.Thread(target=get, args=(i,)) for i in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        assert set(codes) <= {200, 503} and 200 in codes and 503 in codes
        assert all(r == "2" for r in retry)
    finally:
        proc.terminate()
        proc.wait(30)


def test_one_client_address_holds_at_most_its_share_of_sessions():
    """32 idle sockets from one client locked everyone out; now one address gets
    max_sessions_per_client and the next is refused with 1013, naming why."""
    with TestClient(create_app(Settings(max_sessions_per_client=2))) as c:
        with c.websocket_connect("/ws") as a, c.websocket_connect("/ws") as b:
            a.receive_json(), b.receive_json()
            with c.websocket_connect("/ws") as third:
                msg = third.receive_json()
                assert msg["type"] == "error" and "2 sessions" in msg["msg"]
                m = third.receive()
                assert m["type"] == "websocket.close" and m["code"] == 1013


def test_quiet_and_unacknowledging_sockets_are_closed_with_a_reason():
    with TestClient(create_app(Settings(idle_timeout_s=1.0, ack_timeout_s=60))) as c:
        with c.websocket_connect("/ws?play=0") as ws:
            ws.receive_json(), ws.receive_json()
            while True:
                m = ws.receive()
                if m["type"] == "websocket.close":
                    break
            assert m["code"] == 4408 and "idle" in m["reason"]
    with TestClient(create_app(Settings(idle_timeout_s=600, ack_timeout_s=1.0))) as c:
        with c.websocket_connect("/ws") as ws:
            ws.receive_json(), ws.receive_json()
            ws.send_json({"type": "view", "width": 32, "height": 32})
            t0 = time.monotonic()
            while True:                       # frames arrive; none is acknowledged
                m = ws.receive()
                if m["type"] == "websocket.close":
                    break
            assert m["code"] == 4408 and "unacknowledged" in m["reason"]
            assert time.monotonic() - t0 < 10


@pytest.mark.parametrize("origin,host,scheme,ok", [
    ("http://fog.example", "fog.example", "ws", True),
    ("http://fog.example:80", "fog.example", "ws", True),
    ("https://fog.example", "fog.example", "ws", False),      # the scheme counts
    ("http://fog.example", "fog.example", "wss", False),
    ("https://fog.example", "fog.example", "wss", True),
    ("https://fog.example:443", "fog.example:443", "wss", True),
    ("http://fog.example:8000", "fog.example:8001", "ws", False),
    ("http://evil.example", "fog.example", "ws", False),
    ("null", "fog.example", "ws", False),
])
def test_origin_is_compared_by_scheme_host_and_port(origin, host, scheme, ok):
    from fogbank.service.security import origin_allowed
    assert origin_allowed(origin, host, "", scheme) is ok


def test_a_still_beyond_the_cost_budget_is_a_422_naming_what_to_reduce(client):
    body = {"width": 1920, "height": 1080,
            "layers": [{"kind": "noise", "mode": "volume", "samples": 128} for _ in range(16)]}
    r = client.post("/api/still", json=body)
    assert r.status_code == 422
    e = r.json()["detail"][0]
    assert e["type"] == "cost" and e["loc"] == ["body"]
    assert "layers[0] (noise, volume, 128 samples)" in e["msg"] and "fog_scale" in e["msg"]
    r = client.get("/api/still.png?width=4000&height=3000")
    assert r.status_code == 422
    assert r.json()["detail"][0]["loc"] == ["query", "width"] and "MiB" in r.json()["detail"][0]["msg"]


def test_transmittance_is_bounded(client):
    ray = {"origin": [0, 5, 0], "direction": [1, 0, 0], "length": 100}
    r = client.post("/api/transmittance", json={"rays": [dict(ray, time=float(t)) for t in range(17)]})
    assert r.status_code == 422 and "17 distinct ray times" in r.json()["detail"][0]["msg"]
    heavy = {"layers": [{"kind": "particles", "count": 64, "life_min": 900, "life_max": 1000, "seed": i}
                        for i in range(16)]}
    r = client.post("/api/transmittance", json={"params": heavy,
                                                "rays": [dict(ray, time=float(t)) for t in range(16)]})
    assert r.status_code == 422
    assert r.json()["detail"][0]["type"] == "cost" and "distinct times" in r.json()["detail"][0]["msg"]
    ok = {"layers": [{"kind": "particles", "count": 256}]}
    r = client.post("/api/transmittance", json={"params": ok, "rays": [dict(ray, time=float(t)) for t in range(16)]})
    assert r.status_code == 200 and len(r.json()["transmittance"]) == 16


def test_a_tiny_still_of_sixteen_volume_noise_layers_is_drawn(client):
    """Found by an outside attack (issue 9): this still's fog program took over 30 s to
    compile, 16 inlined copies of the noise march, and was refused for its compile time.
    Layers of one kind are now one loop in the program (kinds/packing.py layer_code): it
    compiles in about a second, is estimated so, and is drawn."""
    import io

    from PIL import Image
    body = {"width": 16, "height": 16, "layers": [{"kind": "noise", "mode": "volume", "samples": 1}] * 16}
    r = client.post("/api/still", json=body)
    assert r.status_code == 200
    assert Image.open(io.BytesIO(r.content)).size == (16, 16)


def test_readyz_turns_to_draining_when_shutdown_begins():
    """The server's SIGTERM handler calls app.state.drain() (cli.py) before uvicorn's own."""
    with TestClient(create_app()) as c:
        assert c.get("/readyz").json()["status"] == "ready"
        c.app.state.drain()
        r = c.get("/readyz")
        assert (r.status_code, r.json()["status"]) == (503, "draining")
        assert c.get("/healthz").status_code == 200          # alive, just not taking work


def test_other_hosts_are_refused_against_dns_rebinding(client):
    """Issue 33 finding 9: Host and Origin evil.com:8051 (a site whose name was made to
    resolve to this server) got 101 on /ws. Now only the allowed names are answered (the
    defaults: localhost, 127.0.0.1, ::1); health and metrics answer any host (probes
    address a pod by its IP)."""
    r = client.get("/", headers={"host": "evil.com:8051"})
    assert r.status_code == 400
    err = r.json()["detail"][0]
    assert err["loc"] == ["header", "host"] and "'evil.com:8051'" in err["msg"]
    assert "FOGBANK_ALLOWED_HOSTS" in err["msg"] and "localhost" in err["msg"]
    assert client.post("/api/still", json={}, headers={"host": "evil.com"}).status_code == 400
    with pytest.raises(WebSocketDisconnect) as exc:
        with client.websocket_connect("/ws", headers={"host": "evil.com:8051", "origin": "http://evil.com:8051"}) as ws:
            ws.receive_json()
    assert exc.value.code == 1008
    for host in ("localhost:8000", "127.0.0.1", "[::1]:8051", "LOCALHOST"):
        assert client.get("/api/presets", headers={"host": host}).status_code == 200
    for path in ("/healthz", "/readyz", "/metrics"):   # a probe or scraper names the pod's address
        assert client.get(path, headers={"host": "10.244.3.7:8000"}).status_code == 200
        assert client.get(path, headers={"host": "[fd00::7]:8000"}).status_code == 200
        # a rebinding page needs a name: the metrics are not read through one
        assert client.get(path, headers={"host": "evil.com:8051"}).status_code == 400
    assert client.get("/api/presets", headers={"host": "10.244.3.7:8000"}).status_code == 400


def test_allowed_hosts_add_the_bound_address_and_take_a_star():
    from fogbank.service.security import allowed_hosts, host_allowed
    hosts = allowed_hosts("localhost, fog.example.org", "192.168.1.5")
    assert hosts == {"localhost", "fog.example.org", "192.168.1.5"}
    assert allowed_hosts("localhost", "0.0.0.0") == {"localhost"}
    assert host_allowed("fog.example.org:443", hosts) and not host_allowed("evil.org", hosts)
    assert not host_allowed(None, hosts) and not host_allowed("[bad", hosts)
    assert host_allowed("anything", allowed_hosts("*", "0.0.0.0"))
    assert host_allowed("10.0.0.1:80", hosts, address_too=True) and not host_allowed("10.0.0.1:80", hosts)
    assert not host_allowed("evil.org", hosts, address_too=True)
    assert host_allowed(None, hosts, address_too=True)   # an HTTP/1.0 probe without Host
