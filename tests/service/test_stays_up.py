"""The service stays up (a real server process, its render workers, real GL):

- a heavy still renders in a worker while /healthz, /metrics and small stills answer and
  a stream keeps getting frames (it froze the whole process for 57 s before);
- a still past its deadline is stopped (its worker killed and replaced) and answered
  with 503 + Retry-After, and the service goes on;
- memory of the whole process tree stays within budget under stills and streams of
  many sizes (20 stills at 1280..1299 x 720 took RSS from 164 MB to 1.84 GB before);
- request limits answer in JSON before anything is parsed."""

from __future__ import annotations

import asyncio
import http.client
import json
import socket
import threading
import time
import urllib.error
import urllib.request

import pytest
import websockets

from fogbank.workers import proctree
from servers import HEAVY, Server, post_still, run_async, watch_stream

def get(url: str, timeout: float = 30) -> tuple[int, float, bytes]:
    t0 = time.monotonic()
    try:
        with urllib.request.urlopen(url, timeout=timeout) as r:
            return r.status, time.monotonic() - t0, r.read()
    except urllib.error.HTTPError as e:
        return e.code, time.monotonic() - t0, e.read()


@pytest.fixture(scope="module")
def server():
    srv = Server().start()
    yield srv
    srv.stop()


def test_everyone_is_served_while_a_heavy_still_renders(server):
    url = server.url
    result = {}
    t = threading.Thread(target=lambda: result.update(r=post_still(url, HEAVY)))
    t0 = time.monotonic()
    t.start()
    time.sleep(0.5)
    health = [get(url + "/healthz") for _ in range(10)]
    metrics = get(url + "/metrics")
    small = get(url + "/api/still.jpg?width=320&height=180&time=11")
    frames = run_async(watch_stream(url, 3.0))
    busy_for = time.monotonic() - t0
    t.join(120)
    status, _, png = result["r"]
    heavy_s = time.monotonic() - t0
    print(f"\nheavy still {heavy_s:.1f} s; healthz max {max(h[1] for h in health) * 1000:.0f} ms; "
          f"small still {small[1]:.2f} s; {frames} stream frames in 3 s")
    assert status == 200 and png[:8] == b"\x89PNG\r\n\x1a\n"
    assert heavy_s > busy_for                    # it was rendering throughout the checks
    assert all(h[0] == 200 for h in health)
    assert max(h[1] for h in health) < 0.5       # was 57 s
    assert metrics[0] == 200 and metrics[1] < 0.5
    assert small[0] == 200 and small[1] < 2.0
    assert frames >= 5


def test_a_still_past_its_deadline_is_a_503_and_the_service_goes_on():
    # samples of the worker's CPU every 0.2 s: a 1.5 s job is then seen busy to its end (and so blamed)
    srv = Server(env={"FOGBANK_RENDER_TIMEOUT_S": "1.5", "FOGBANK_PROBE_INTERVAL_S": "0.2"}).start()
    try:
        t0 = time.monotonic()
        status, headers, body = post_still(srv.url, HEAVY)
        took = time.monotonic() - t0
        detail = json.loads(body)["detail"]
        assert status == 503
        assert "took over 1.5 s" in detail                  # (the message says why when it fails)
        assert "asked again, it is refused (422)" in detail
        assert headers["Retry-After"] == "5"
        assert took < 6.0                                   # stopped, not waited out
        assert get(srv.url + "/healthz")[0] == 200
        assert get(srv.url + "/api/still.jpg?width=160&height=90&time=4")[0] == 200
        text = get(srv.url + "/metrics")[2].decode()
        assert 'fogbank_deadline_kills_total{lane="batch"} 1.0' in text
        assert 'fogbank_worker_restarts_total{lane="batch",why="deadline"} 1.0' in text
        # issue 33 finding 4: asked again, the same still cost another worker and another 503
        # (its Retry-After invited it); now it is refused at once, naming what to reduce
        t0 = time.monotonic()
        status, _, body = post_still(srv.url, HEAVY)
        assert status == 422 and time.monotonic() - t0 < 2.0
        msg = json.loads(body)["detail"][0]["msg"]
        assert "stopped at its deadline of 1.5 s" in msg and "layers[0] (noise, volume, 128 samples)" in msg
        text = get(srv.url + "/metrics")[2].decode()
        assert 'fogbank_deadline_kills_total{lane="batch"} 1.0' in text     # no second kill
    finally:
        srv.stop()


def test_memory_of_the_process_tree_stays_within_budget():
    """20 stills of different sizes, then 8 viewers at 5 window sizes: the tree stays
    under 2 GiB while they watch (the Deployment's limit), and once they have left it
    settles within 500 MB of its warm size (memory that returns)."""
    srv = Server(env={"FOGBANK_MAX_SESSIONS_PER_CLIENT": "64"}).start()   # 8 viewers from 127.0.0.1
    try:
        get(srv.url + "/api/still.jpg?width=1280&height=720")
        run_async(watch_stream(srv.url, 1.0))
        warm = proctree.tree_rss_bytes(srv.proc.pid)
        for w in range(1280, 1300):
            assert get(srv.url + f"/api/still.jpg?width={w}&height=720", timeout=60)[0] == 200
        after_stills = proctree.tree_rss_bytes(srv.proc.pid)

        async def viewers():
            sizes = [(640, 360), (800, 450), (960, 540), (1280, 720), (1920, 1080)]
            return await asyncio.gather(*(   # and each window is resized every third frame
                watch_stream(srv.url, 8.0, sizes[i % 5], f"v=1&camera.yaw={i * 7}",
                             resize=lambda n, i=i: sizes[(i + n) % 5] if n % 3 == 0 else None)
                for i in range(8)))
        frames = run_async(viewers())
        peak = proctree.tree_rss_bytes(srv.proc.pid)
        # the sessions are gone: their workers finish the frames in flight, drop their
        # scene passes and hold their caches to budget again (a 1920x1080 frame holds
        # ~300 MB while it is the frame just drawn); the tree settles within seconds
        # (sampled for up to 15 s, until no lower value came for 3 s)
        after, start = peak, time.monotonic()
        last_drop = start
        while time.monotonic() - start < 15 and time.monotonic() - last_drop < 3:
            time.sleep(0.5)
            now = proctree.tree_rss_bytes(srv.proc.pid)
            if now < after - (4 << 20):
                last_drop = time.monotonic()
            after = min(after, now)
        mb = 2 ** 20
        print(f"\ntree RSS: warm {warm / mb:.0f} MB, after 20 stills {after_stills / mb:.0f} MB, "
              f"with 8 viewers {peak / mb:.0f} MB, settled {after / mb:.0f} MB; frames per viewer {frames}")
        assert all(n >= 1 for n in frames)
        assert after_stills - warm < 500 * mb
        assert after - warm < 500 * mb
        assert peak < 2 * 1024 * mb
    finally:
        srv.stop()


# ---------------------------------------------------------------- request limits


def raw(port: int, data: bytes, read: int = 65536, timeout: float = 10) -> bytes:
    with socket.create_connection(("127.0.0.1", port), timeout=timeout) as s:
        try:
            s.sendall(data)
        except (BrokenPipeError, ConnectionResetError):
            pass
        out = b""
        try:
            while len(out) < read:
                chunk = s.recv(65536)
                if not chunk:
                    break
                out += chunk
        except (ConnectionResetError, socket.timeout):
            pass
        return out


def status_and_json(resp: bytes) -> tuple[int, dict]:
    head, _, body = resp.partition(b"\r\n\r\n")
    assert b"application/json" in head.lower(), head
    return int(head.split()[1]), json.loads(body)


def test_the_stream_is_not_deflated_though_the_client_offers_it(server):
    """The frames are JPEG: the server declines permessage-deflate (cli.py), which a
    browser and the websockets client offer, and the frames still come."""
    async def go():
        async with websockets.connect(server.url.replace("http", "ws", 1) + "/ws?v=1&time=3") as ws:
            # websockets >= 14's client keeps the handshake as request and response; 12-13's as headers
            request = ws.request.headers if hasattr(ws, "request") else ws.request_headers
            response = ws.response.headers if hasattr(ws, "response") else ws.response_headers
            offered = request.get("Sec-WebSocket-Extensions", "")
            accepted = response.get("Sec-WebSocket-Extensions")
            await ws.recv(), await ws.recv()
            await ws.send(json.dumps({"type": "view", "width": 160, "height": 90, "fps": 30}))
            while not isinstance(frame := await asyncio.wait_for(ws.recv(), 60), bytes):
                pass
            return offered, accepted, frame
    offered, accepted, frame = run_async(go())
    assert "permessage-deflate" in offered
    assert accepted is None
    assert frame[-2:] == b"\xff\xd9"   # a whole JPEG (its end-of-image marker)


def test_a_100_mb_body_is_refused_before_it_is_read(server):
    before = proctree.tree_rss_bytes(server.proc.pid)
    c = http.client.HTTPConnection("127.0.0.1", server.port, timeout=30)
    c.putrequest("POST", "/api/still")
    c.putheader("Content-Type", "application/json")
    c.putheader("Content-Length", str(100 << 20))
    c.endheaders()
    r = c.getresponse()
    assert r.status == 413
    assert "at most" in json.loads(r.read())["detail"][0]["msg"]
    # and without a Content-Length: counted as it arrives
    head = (b"POST /api/still HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
            b"Transfer-Encoding: chunked\r\n\r\n")
    chunk = b"%x\r\n" % (1 << 20) + b" " * (1 << 20) + b"\r\n"
    status, body = status_and_json(raw(server.port, head + chunk * 4))
    assert status == 413 and body["detail"][0]["loc"] == ["body"]
    assert proctree.tree_rss_bytes(server.proc.pid) - before < 50 << 20


def test_over_long_urls_and_headers_get_json(server):
    status, body = status_and_json(raw(server.port, b"GET /api/still.png?" + b"a" * 100_000 +
                                       b" HTTP/1.1\r\nHost: x\r\n\r\n"))
    assert status == 414 and "32768" in body["detail"][0]["msg"]
    many = b"".join(b"X-%d: y\r\n" % i for i in range(100_000))
    status, body = status_and_json(raw(server.port, b"GET /healthz HTTP/1.1\r\nHost: x\r\n" + many + b"\r\n"))
    assert status in (400, 431) and body["detail"]
    huge = b"X-Big: " + b"a" * (8 << 20) + b"\r\n"
    status, body = status_and_json(raw(server.port, b"GET /healthz HTTP/1.1\r\nHost: x\r\n" + huge + b"\r\n"))
    assert status == 400 and "exceed" in body["detail"][0]["msg"]
    status, body = status_and_json(raw(server.port, b"GET /healthz HTTP/1.1\r\nHost: x\r\n" +
                                       b"".join(b"X-%d: y\r\n" % i for i in range(150)) + b"\r\n"))
    assert status == 431 and body["detail"][0]["loc"] == ["headers"]
    assert get(server.url + "/healthz")[0] == 200


def page_and_length(resp: bytes) -> tuple[int, str, str]:
    """(status, content type, the sentence that says how long the link is) of a 414."""
    head, _, body = resp.partition(b"\r\n\r\n")
    ctype = next(line.split(b":", 1)[1].strip().decode() for line in head.split(b"\r\n")[1:]
                 if line.lower().startswith(b"content-type:"))
    sentence = body.decode().split('<p id="length">', 1)[1].split("</p>", 1)[0]
    assert "Copy link" in body.decode() and "compact" in body.decode()
    return int(head.split()[1]), ctype, sentence


@pytest.mark.parametrize("n", [100_000, 1_000_000, 2_000_000])
def test_an_over_long_link_gets_a_page_that_explains(server, n):
    """A browser that opens an over-long link gets a page (issue 12: a bare "Invalid HTTP
    request" at 100k characters) saying how long it is, the limit, and that "Copy link"
    makes compact links; the API's routes answer the same 414 in JSON."""
    from fogbank.service.limits import MAX_HEAD_BYTES
    from fogbank.settings import Settings
    target = b"/?v=1&density=2&pad=" + b"a" * (n - 20)
    limit = Settings().max_url_bytes
    length = f"{len(target):,} characters long" if len(target) < MAX_HEAD_BYTES else \
        f"more than {MAX_HEAD_BYTES:,} characters long"
    assert page_and_length(raw(server.port, b"GET " + target + b" HTTP/1.1\r\nHost: x\r\n\r\n")) == \
        (414, "text/html; charset=utf-8", f"It is {length}; this server takes links of at most {limit:,} characters.")
    status, body = status_and_json(raw(server.port, b"GET /api/still.png" + target[1:] + b" HTTP/1.1\r\n"
                                                    b"Host: x\r\nAccept: text/html\r\n\r\n"))
    assert status == 414 and body["detail"][0]["loc"] == ["url"] and f"at most {limit}" in body["detail"][0]["msg"]
    assert get(server.url + "/healthz")[0] == 200


def test_head_is_answered(server):
    for path in ("/", "/healthz", "/readyz"):
        c = http.client.HTTPConnection("127.0.0.1", server.port, timeout=10)
        c.request("HEAD", path)
        r = c.getresponse()
        assert (path, r.status) == (path, 200)
        assert r.read() == b""


def test_healthz_fails_while_no_worker_renders_and_readyz_says_why():
    """/healthz said ok while every still was 503 and streams were at 0 frames."""
    import os
    import signal
    srv = Server(env={"FOGBANK_LIVENESS_S": "1.5", "FOGBANK_PROBE_INTERVAL_S": "0.2",
                      "FOGBANK_PROBE_DEADLINE_S": "60", "FOGBANK_WORKER_START_S": "60"}).start()
    workers = [p for p in proctree.descendants(srv.proc.pid)
               if p != srv.proc.pid and "spawn_main" in open(f"/proc/{p}/cmdline").read()
               and "resource_tracker" not in open(f"/proc/{p}/cmdline").read()]
    try:
        assert len(workers) == 2 and get(srv.url + "/healthz")[0] == 200
        for p in workers:
            os.kill(p, signal.SIGSTOP)          # hung: alive, rendering nothing
        time.sleep(3.0)
        status, took, body = get(srv.url + "/healthz")
        assert status == 503 and took < 0.5
        assert json.loads(body)["status"] == "failing"
        status, _, body = get(srv.url + "/readyz")
        assert status == 503 and json.loads(body)["status"] == "failing"
        for p in workers:
            os.kill(p, signal.SIGCONT)
        # back once the workers render: the continued ones, or their replacements if the
        # stall was found first (3 s without progress; a new worker warms up in about 7 s)
        for _ in range(60):
            if get(srv.url + "/healthz")[0] == 200 and get(srv.url + "/readyz")[0] == 200:
                break
            time.sleep(0.5)
        assert get(srv.url + "/healthz")[0] == 200
        assert get(srv.url + "/readyz")[0] == 200
    finally:
        for p in workers:
            try:
                os.kill(p, signal.SIGCONT)
            except ProcessLookupError:
                pass
        srv.stop()


def test_the_per_client_cap_holds_when_sessions_connect_at_once():
    """The caps were checked before a session was counted: 8 sockets opened at once all
    passed a cap of 4."""
    srv = Server(env={"FOGBANK_MAX_SESSIONS_PER_CLIENT": "3"}).start()
    try:
        async def one():
            async with websockets.connect(srv.url.replace("http", "ws", 1) + "/ws") as ws:
                first = json.loads(await ws.recv())
                if first["type"] == "hello":
                    await asyncio.sleep(1.0)          # hold the session while the others try
                    return "open"
                try:
                    await ws.recv()
                except websockets.ConnectionClosed as exc:
                    return exc.rcvd.code if exc.rcvd else None

        async def burst():
            return await asyncio.gather(*(one() for _ in range(8)))
        got = run_async(burst())
        assert sorted(got, key=str) == sorted(["open"] * 3 + [1013] * 5, key=str)
    finally:
        srv.stop()


def _lane_pid(url: str, lane: str) -> int:
    body = json.loads(get(url + "/healthz")[2])
    return next(w["pid"] for w in body["workers"] if w["lane"] == lane)


def test_a_stalled_worker_is_the_servers_fault_and_the_stream_goes_on():
    """Issue 33, findings 2 and 3: the interactive worker stopped (SIGSTOP) during a
    playing stream. Before, the frame deadline paused the session with "this look took over
    10 s a frame ... make it cheaper", no frame came for the next 47 s, and /healthz and
    /readyz said 200 throughout. Now the stall is found by the worker's CPU time (none used
    while jobs wait or run), the worker is replaced, the lost frame is drawn again on the
    new one, the client is told the renderer stalled, and both probes say 503 while the
    lane cannot render."""
    import os
    import signal
    srv = Server(env={"FOGBANK_FRAME_DEADLINE_S": "4"}).start()
    pid = _lane_pid(srv.url, "interactive")
    probes: list[tuple[float, int, int]] = []
    done = threading.Event()
    t0 = time.monotonic()

    def poll():
        while not done.is_set():
            probes.append((time.monotonic() - t0, get(srv.url + "/healthz", timeout=5)[0],
                           get(srv.url + "/readyz", timeout=5)[0]))
            time.sleep(0.3)

    async def watch():
        frames, texts, stopped = [], [], None
        async with websockets.connect(srv.url.replace("http", "ws", 1) + "/ws?v=1&time=3") as ws:
            await ws.recv(), await ws.recv()
            await ws.send(json.dumps({"type": "view", "width": 320, "height": 180, "fps": 15}))
            await ws.send(json.dumps({"type": "play", "playing": True}))
            while time.monotonic() - t0 < 45:
                if stopped is None and time.monotonic() - t0 > 4:
                    os.kill(pid, signal.SIGSTOP)
                    stopped = time.monotonic() - t0
                try:
                    m = await asyncio.wait_for(ws.recv(), 0.5)
                except asyncio.TimeoutError:
                    continue
                if isinstance(m, bytes):
                    frames.append(time.monotonic() - t0)
                    await ws.send(json.dumps({"type": "ack", "frame": int.from_bytes(m[4:8], "little")}))
                else:
                    texts.append(json.loads(m))
        return frames, texts, stopped

    poller = threading.Thread(target=poll, daemon=True)
    poller.start()
    try:
        frames, texts, stopped = run_async(watch())
        done.set()
        poller.join(10)
        errors = [m.get("msg", "") for m in texts if m.get("type") == "error"]
        before = [t for t in frames if t < stopped]
        after = [t for t in frames if t > stopped + 1.0]
        during = [(h, r) for t, h, r in probes if stopped < t < (after[0] if after else 45)]
        print(f"\nframes before the stop {len(before)}, first after it at +{after[0] - stopped:.1f} s, "
              f"{len(after)} after; probes while stalled (healthz, readyz) {sorted(set(during))}; "
              f"errors {errors}")
        assert len(before) >= 5
        assert after and after[0] - stopped < 25.0           # was: none for 47 s
        assert len(after) >= 20
        assert any("stalled" in e for e in errors)
        assert not any("took over" in e or "paused" in e for e in errors)
        assert any(h == 503 for h, _ in during) and any(r == 503 for _, r in during)
        assert probes[-1][1:] == (200, 200)
        for _ in range(50):
            if not os.path.exists(f"/proc/{pid}") or open(f"/proc/{pid}/stat").read().split()[2] == "Z":
                break
            time.sleep(0.2)
        assert not os.path.exists(f"/proc/{pid}") or open(f"/proc/{pid}/stat").read().split()[2] == "Z"
    finally:
        done.set()
        try:
            os.kill(pid, signal.SIGCONT)
        except ProcessLookupError:
            pass
        srv.stop()


def test_a_stalled_batch_lane_fails_readiness_not_liveness():
    """Issue 33 finding 3: health counted any live worker. With the batch worker stopped,
    /readyz says 503 and names the batch lane while it cannot render (stills sent here would
    wait on it), /healthz stays 200 (the streams' lane renders), and both are 200 again once
    the stalled worker is replaced."""
    import os
    import signal
    srv = Server().start()
    pid = _lane_pid(srv.url, "batch")
    try:
        os.kill(pid, signal.SIGSTOP)
        t0, seen = time.monotonic(), []
        while time.monotonic() - t0 < 40:
            h, r = get(srv.url + "/healthz", timeout=5), get(srv.url + "/readyz", timeout=5)
            seen.append((round(time.monotonic() - t0, 1), h[0], r[0], json.loads(r[2]).get("reason")))
            if any(s[2] == 503 for s in seen) and r[0] == 200:
                break
            time.sleep(0.3)
        print("\n(s, healthz, readyz, reason):", [s for s in seen if s[2] == 503][:1], seen[-1])
        assert all(s[1] == 200 for s in seen)
        failing = [s for s in seen if s[2] == 503]
        assert failing and failing[0][3] == "the batch lane cannot render"
        assert seen[-1][1:3] == (200, 200)
        assert _lane_pid(srv.url, "batch") != pid
    finally:
        try:
            os.kill(pid, signal.SIGCONT)
        except ProcessLookupError:
            pass
        srv.stop()


def _metric(url: str, name: str) -> float:
    text = get(url + "/metrics")[2].decode()
    return sum(float(line.rsplit(" ", 1)[1]) for line in text.splitlines()
               if line.startswith(name) and not line.startswith("#"))


def test_identical_stills_are_rendered_once_and_a_burst_waits_instead_of_failing():
    """Issue 33 finding 5: 200 concurrent GETs of one uncached still made 4 renders and 196
    answers of 503. Now one render serves them all (single flight); a burst of distinct
    stills beyond max_stills waits for a place; past max_queued_stills it is 503."""
    from concurrent.futures import ThreadPoolExecutor
    srv = Server(env={"FOGBANK_MAX_QUEUED_STILLS": "6"}).start()
    try:
        url = srv.url + "/api/still.jpg?width=480&height=270&time=7.25"
        before = _metric(srv.url, "fogbank_stills_total")
        with ThreadPoolExecutor(200) as pool:
            got = list(pool.map(lambda _: get(url, timeout=120), range(200)))
        renders = _metric(srv.url, "fogbank_stills_total") - before
        statuses = sorted({g[0] for g in got})
        print(f"\n200 identical GETs: statuses {statuses}, {renders:.0f} render(s), "
              f"slowest {max(g[1] for g in got):.1f} s")
        assert statuses == [200]
        assert len({g[2] for g in got}) == 1 and got[0][2][:2] == b"\xff\xd8"
        assert renders == 1
        # 10 distinct stills at once: 4 render, 6 wait, none refused
        with ThreadPoolExecutor(10) as pool:
            burst = list(pool.map(lambda i: get(srv.url + f"/api/still.jpg?width=320&height=180&time={i}.5",
                                                timeout=120)[0], range(10)))
        assert burst == [200] * 10
        # 16 more: 4 render, 6 wait, the other 6 are told to retry
        with ThreadPoolExecutor(16) as pool:
            over = list(pool.map(lambda i: get(srv.url + f"/api/still.jpg?width=320&height=180&time={i}.75",
                                               timeout=120), range(16)))
        refused = [json.loads(o[2])["detail"] for o in over if o[0] == 503]
        print(f"16 distinct at once: {sum(o[0] == 200 for o in over)} rendered, {len(refused)} refused")
        assert sum(o[0] == 200 for o in over) >= 10 and len(refused) >= 1
        assert all("FOGBANK_MAX_QUEUED_STILLS" in r for r in refused)
    finally:
        srv.stop()


def test_sessions_that_render_nothing_give_their_place_to_new_ones():
    """Issue 33 finding 6: 32 sockets from 32 addresses that never send a message held all
    32 sessions until the 30 s ack timeout (a new client refused with 1013 all that time),
    and paused sessions held theirs for the 300 s idle timeout. Admission now counts render
    capacity: when full, the session quiet longest without rendering (silent past
    silent_yield_s, or paused and quiet past yield_after_s) is closed with 4408 and a
    reason, and the newcomer is let in; sessions that play are never closed for it."""
    srv = Server(env={"FOGBANK_MAX_SESSIONS": "3", "FOGBANK_SILENT_YIELD_S": "2",
                      "FOGBANK_YIELD_AFTER_S": "3"}).start()
    ws_url = srv.url.replace("http", "ws", 1) + "/ws?v=1&time=3"

    async def closed_with(ws) -> tuple:
        try:
            while True:
                await asyncio.wait_for(ws.recv(), 10)
        except websockets.ConnectionClosed as exc:
            return (exc.rcvd.code, exc.rcvd.reason) if exc.rcvd else (None, "")

    async def newcomer() -> str:
        async with websockets.connect(ws_url) as ws:
            first = json.loads(await ws.recv())
            return first["type"] if first["type"] == "hello" else first["msg"]

    async def silent():
        socks = [await websockets.connect(ws_url) for _ in range(3)]
        for s in socks:
            assert json.loads(await s.recv())["type"] == "hello"
        assert "full" in await newcomer()                  # within silent_yield_s: refused
        await asyncio.sleep(2.5)
        assert await newcomer() == "hello"
        codes = await asyncio.gather(*(closed_with(s) for s in socks[:1]))
        for s in socks:
            await s.close()
        return codes

    async def paused_and_playing():
        async def viewer(play: bool, seconds: float):
            ws = await websockets.connect(ws_url)
            await ws.recv(), await ws.recv()
            await ws.send(json.dumps({"type": "view", "width": 64, "height": 36, "fps": 10}))
            await ws.send(json.dumps({"type": "play", "playing": play}))
            t0 = time.monotonic()
            while time.monotonic() - t0 < seconds:
                try:
                    m = await asyncio.wait_for(ws.recv(), 0.3)
                except asyncio.TimeoutError:
                    continue
                except websockets.ConnectionClosed as exc:
                    return ("closed", exc.rcvd.code if exc.rcvd else None, exc.rcvd.reason if exc.rcvd else "")
                if isinstance(m, bytes):
                    await ws.send(json.dumps({"type": "ack", "frame": int.from_bytes(m[4:8], "little")}))
            await ws.close()
            return ("open",)

        async def late():
            await asyncio.sleep(4.5)
            return await newcomer()
        return await asyncio.gather(viewer(False, 8), viewer(True, 8), viewer(True, 8), late())

    try:
        codes = run_async(silent())
        assert codes[0][0] == 4408 and "without a message" in codes[0][1]
        time.sleep(1.0)
        paused, playing1, playing2, late = run_async(paused_and_playing())
        print(f"\nsilent: {codes}; paused: {paused}; playing: {playing1}, {playing2}; newcomer: {late}")
        assert late == "hello"
        assert paused[:2] == ("closed", 4408) and "paused" in paused[2]
        assert playing1 == playing2 == ("open",)
    finally:
        srv.stop()


def test_a_socket_closed_right_after_its_handshake_logs_no_error(server):
    """Issue 33 finding 9: each socket closed right after the WebSocket handshake logged an
    "Exception in ASGI application" traceback (the hello went to a closed socket)."""
    import base64
    import os
    before = server.logs().count("Exception in ASGI application")
    for _ in range(5):
        with socket.create_connection(("127.0.0.1", server.port), timeout=10) as s:
            key = base64.b64encode(os.urandom(16)).decode()
            s.sendall(f"GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{server.port}\r\nUpgrade: websocket\r\n"
                      f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n".encode())
            assert s.recv(12) == b"HTTP/1.1 101"
    time.sleep(1.0)
    logs = server.logs()
    assert logs.count("Exception in ASGI application") == before
    assert logs.count("session closed during its handshake") >= 1
    assert get(server.url + "/healthz")[0] == 200


def test_a_websocket_for_another_host_is_refused(server):
    """Issue 33 finding 9, as found: Host and Origin evil.com:8051 got 101 Switching Protocols."""
    import base64
    import os
    with socket.create_connection(("127.0.0.1", server.port), timeout=10) as s:
        key = base64.b64encode(os.urandom(16)).decode()
        s.sendall(f"GET /ws HTTP/1.1\r\nHost: evil.com:8051\r\nOrigin: http://evil.com:8051\r\nUpgrade: websocket\r\n"
                  f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n".encode())
        assert s.recv(12) == b"HTTP/1.1 403"


def _slow(port: int, head: bytes, then: bytes, every: float, seconds: float) -> tuple[bytes, float]:
    """Send `head`, then `then` a byte every `every` s until the server answers or closes;
    (what it answered, when)."""
    t0 = time.monotonic()
    with socket.create_connection(("127.0.0.1", port), timeout=seconds) as s:
        s.sendall(head)
        s.settimeout(every)
        got = b""
        for b in then:
            try:
                chunk = s.recv(4096)
                if not chunk:
                    break
                got += chunk
                break
            except socket.timeout:
                pass
            try:
                s.sendall(bytes([b]))
            except (BrokenPipeError, ConnectionResetError):
                break
            if time.monotonic() - t0 > seconds:
                break
        s.settimeout(2)
        try:
            got += s.recv(4096)
        except (socket.timeout, ConnectionResetError):
            pass
    return got, time.monotonic() - t0


def test_slow_heads_and_bodies_are_timed_out():
    """Issue 33 finding 9: slow headers and slow bodies were never timed out (20 sockets
    held 60 s). A head must come within head_timeout_s, a body within body_timeout_s of
    its head (2 and 3 s here), else a JSON 408 and the connection closed; a socket that
    sends nothing is closed too. Requests within them are answered."""
    from concurrent.futures import ThreadPoolExecutor
    srv = Server(env={"FOGBANK_HEAD_TIMEOUT_S": "2", "FOGBANK_BODY_TIMEOUT_S": "3"}).start()
    try:
        port = srv.port
        heads = b"GET /api/presets HTTP/1.1\r\nHost: 127.0.0.1\r\n"
        with ThreadPoolExecutor(20) as pool:
            slow_heads = list(pool.map(lambda _: _slow(port, heads, b"X-Slow: " + b"a" * 200, 0.5, 30), range(20)))
        body_head = (b"POST /api/still HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
                     b"Content-Length: 400\r\n\r\n")
        slow_body = _slow(port, body_head, b"{" + b" " * 398 + b"}", 0.5, 30)
        with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
            s.settimeout(10)
            t0 = time.monotonic()
            s.sendall(b"")
            quiet = s.recv(10)          # nothing sent: closed with nothing said
            quiet_s = time.monotonic() - t0
        print(f"\nslow heads: {sorted({g[0][:12] for g in slow_heads})}, "
              f"longest {max(g[1] for g in slow_heads):.1f} s; slow body: {slow_body[0][:12]} "
              f"in {slow_body[1]:.1f} s; a silent socket closed in {quiet_s:.1f} s")
        for got, took in slow_heads:
            assert got.startswith(b"HTTP/1.1 408") and took < 6.0
            assert b'"request"' in got and b"within 2 s" in got
        assert slow_body[0].startswith(b"HTTP/1.1 408") and b"body did not arrive within 3 s" in slow_body[0]
        assert slow_body[1] < 7.0
        assert quiet == b"" and quiet_s < 5.0
        assert get(srv.url + "/api/presets")[0] == 200
        # pipelined: a request, then the next one's head whose body never comes; the second
        # is timed as a body (it was given the head's time, and told its head was late)
        with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
            s.settimeout(10)
            t0 = time.monotonic()
            s.sendall(b"GET /api/presets HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n" + body_head + b"{")
            piped = b""
            while chunk := s.recv(65536):
                piped += chunk
            piped_s = time.monotonic() - t0
        print(f"pipelined body that never came: closed in {piped_s:.1f} s")
        assert piped.startswith(b"HTTP/1.1 200") and piped.count(b"HTTP/1.1 408") == 1
        assert b"body did not arrive within 3 s" in piped and 2.5 < piped_s < 7.0
        # slow, but within the limits: answered
        got, took = _slow(port, b"GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\n", b"\r\n", 0.6, 10)
        assert got.startswith(b"HTTP/1.1 200")
    finally:
        srv.stop()


def test_a_costly_look_does_not_starve_a_stream_on_its_worker():
    """Issue 33 finding 1, as scripts/fair_share.py measures it: a 640x360 stream of the
    default look, alone and then beside a session playing 16 layers of volume noise at
    1920x1080 on the same (only) interactive worker. Turns by frame, and the costly look
    climbing while quiet to first frames of 6.5 s, gave the stream 0.2 frames a second
    with gaps of 6 s; by time (about 0.7 of its rate kept here, and no gap near 1 s), it
    must keep 40% of its rate and no gap over 1.5 s, for the suite's load. A frame rate is
    the machine's as much as the code's: CI's run, loaded by something else for a while,
    measured 0.11 once (its other frame-rate tests missed too), so a miss is measured once
    more before it fails (a starving scheduler misses both; scripts/fair_share.py gives the
    numbers). With two CPU burners beside it, 0.40 (gaps 1.8 s) before the scheduler's
    hold was bounded by cost ratio (FAIR_HOLD_RATIO), 0.65-0.70 (gaps 0.1-0.6 s) after."""
    from fogbank.model import presets as P
    from fogbank.model.params import FogParams
    from fogbank.model.urlstate import encode
    look = P.preset_dict("default")
    look["layers"] = [{"kind": "noise", "mode": "volume", "density": 0.3}] * 16
    hostile_q = encode(FogParams.model_validate(look))
    srv = Server().start()
    ws_url = srv.url.replace("http", "ws", 1)

    async def stream(query, size, seconds, stop=None):
        async with websockets.connect(f"{ws_url}/ws?{query}", max_size=None) as ws:
            await ws.recv(), await ws.recv()
            await ws.send(json.dumps({"type": "view", "width": size[0], "height": size[1], "fps": 30}))
            await ws.send(json.dumps({"type": "play", "playing": True}))
            times, t0 = [], time.monotonic()
            while (stop is None and time.monotonic() - t0 < seconds) or (stop is not None and not stop.is_set()):
                try:
                    m = await asyncio.wait_for(ws.recv(), 0.5)
                except asyncio.TimeoutError:
                    continue
                if isinstance(m, bytes):
                    if time.monotonic() - t0 > 2.0:
                        times.append(time.monotonic())
                    await ws.send(json.dumps({"type": "ack", "frame": int.from_bytes(m[4:8], "little")}))
            return times

    def rate(times):
        gaps = [b - a for a, b in zip(times, times[1:])]
        return (len(times) - 1) / (times[-1] - times[0]), max(gaps)

    async def both():
        alone = await stream("v=1&time=3", (640, 360), 10)
        stop = asyncio.Event()
        h = asyncio.create_task(stream(hostile_q, (1920, 1080), 0, stop))
        await asyncio.sleep(4.0)
        beside = await stream("v=1&time=3", (640, 360), 12)
        stop.set()
        hostile = await h
        return alone, beside, hostile

    tries = []
    try:
        for _ in range(2):   # once more only where the first missed: see the docstring
            alone, beside, hostile = run_async(both())
            (fa, ga), (fb, gb) = rate(alone), rate(beside)
            tries.append({"alone_fps": round(fa, 1), "beside_fps": round(fb, 1), "kept": round(fb / fa, 2),
                          "longest_gap_s": round(gb, 2), "costly_frames": len(hostile)})
            print(f"\nalone {fa:.1f} fps (longest gap {ga:.2f} s); beside the costly look {fb:.1f} fps "
                  f"(longest gap {gb:.2f} s), kept {fb / fa:.2f}; the costly look drew {len(hostile)} frames")
            if fb >= 0.4 * fa and gb < 1.5 and len(hostile) >= 10:
                break
        print("tries:", tries)
        assert fb >= 0.4 * fa
        assert gb < 1.5
        assert len(hostile) >= 10                 # drawn, cheaper or slower, not refused
    finally:
        srv.stop()
