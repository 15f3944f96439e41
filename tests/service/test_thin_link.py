"""A stream that fits the link (issue 34), through the loopback relay (tools/relay.py): a
real server on 127.0.0.1, a client that acks every frame and answers pings as the page
does, and links of 5, 2 and 1 Mbit/s with 40 ms of round trip.

References: the relay's own pacing, checked against a clock and a byte count; the bytes
and frames the client received; and what frames of the view's size would cost on the
link (a 1280x720 frame of the default look at quality 80 is about 29 KB, so 1 Mbit/s
carries 4.3 of them a second: the stream before the rate controller)."""

from __future__ import annotations

import socket
import threading
import time

import pytest

from fogbank.tools.link import orbit_through, sixteen_layer_query, watch_through
from fogbank.tools.relay import Relay
from servers import Server


@pytest.fixture(scope="module")
def server():
    s = Server(env={"FOGBANK_MAX_SESSIONS_PER_CLIENT": "100"}).start()
    yield s
    s.stop()


def _sink():
    """A TCP server on 127.0.0.1 that answers each connection's first byte at once and
    then reads everything; returns (port, received byte counts by connection)."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen()
    got: list[int] = []

    def serve():
        conn, _ = srv.accept()
        with conn:
            conn.sendall(b"!")   # a reply for the round trip
            n = 0
            while data := conn.recv(65536):
                n += len(data)
            got.append(n)
    threading.Thread(target=serve, daemon=True).start()
    return srv, got


def test_the_relay_delays_and_paces_the_server_to_client_direction():
    """Bytes from the server reach the client a round trip late and at the bucket's rate:
    a reply that needs one round trip takes about 40 ms, and 250 KB from the server take
    about 1 s at 2 Mbit/s (both by the client's clock)."""
    srv, _ = _sink()
    port = srv.getsockname()[1]
    with Relay(port, rate_bps=2e6, rtt_ms=40) as relay:
        c = socket.create_connection(("127.0.0.1", relay.port))
        t0 = time.monotonic()
        assert c.recv(1) == b"!"   # the server speaks first: half a round trip down
        assert 0.015 <= time.monotonic() - t0 <= 0.2
        c.close()
    # server -> client paced: a server that sends 250 KB at once
    srv2 = socket.socket()
    srv2.bind(("127.0.0.1", 0))
    srv2.listen()

    def blast():
        conn, _ = srv2.accept()
        with conn:
            conn.sendall(b"x" * 250_000)
    threading.Thread(target=blast, daemon=True).start()
    with Relay(srv2.getsockname()[1], rate_bps=2e6, rtt_ms=40) as relay:
        c = socket.create_connection(("127.0.0.1", relay.port))
        t0 = time.monotonic()
        n = 0
        while n < 250_000:
            data = c.recv(65536)
            assert data
            n += len(data)
        took = time.monotonic() - t0
        c.close()
    assert 0.85 * 1.0 <= took <= 1.25 * 1.0 + 0.05


@pytest.mark.parametrize("mbps", [5, 2, 1])
def test_the_playing_stream_lowers_quality_and_size_to_keep_its_frame_rate(server, mbps):
    """The default look playing at 1280x720: on each link the frames fit it (their bits a
    second under the link's) and come at least 8 a second; on 2 and 1 Mbit/s at least 1.5
    times as often as the view's own 29 KB frames could (8.6 and 4.3 a second: the stream
    before); the link is read within a factor of two, its round trip within 38-80 ms.
    The frame rate is the machine's as much as the code's: CI's run, loaded by something
    else for a while, measured 6.0-6.5 a second on 5 and 2 Mbit/s (two CPU burners here:
    10.5-16.5), so a miss is measured again before it fails; a stream that does not fit
    its link misses every time (JPEG q80 at 720p: 4.3 a second at 1 Mbit/s).
    `fogbank bench-link` gives the numbers."""
    rate = mbps * 1e6
    floor = max(8, 1.5 * rate / 8 / 29_000) if mbps <= 2 else 8   # 13-22 measured here
    tries = []
    for _ in range(3):   # a miss is measured again, twice at most (the docstring says why)
        r = watch_through(server.url, "v=1", rate, 40, 6.0)
        tries.append({k: r[k] for k in ("fps", "frame_mbps", "quality", "width", "link")})
        if r["fps"] >= floor:
            break
    print(tries)
    assert r["frame_mbps"] * 1e6 <= rate
    assert r["fps"] >= floor
    link = r["link"]
    assert 0.5 * rate <= link["rate_bps"] <= 2.0 * rate
    assert 38 <= link["rtt_ms"] <= 80
    if mbps == 1:   # what it gave up: quality and size, not frames
        assert r["quality"] < 80 or r["width"] < 1280


def test_orbiting_a_long_look_on_a_thin_link_sends_cameras_not_looks(server):
    """Issue 34's finding 1 at 1 Mbit/s: orbiting the 16-layer look (its state 20 KB, the
    page sending a camera a frame) keeps the text under a tenth of the link, and frames
    come at 10 or more a second with the control-to-frame p95 at most 400 ms. Before:
    every camera answered with the look, 9.9 Mbit/s of text (0.4 fps at 5 Mbit/s)."""
    r = orbit_through(server.url, sixteen_layer_query(), 1e6, 40, 6.0)
    assert r["text_mbps"] <= 0.1
    assert r["fps"] >= 10      # 21 measured here (0.4 before)
    assert r["lag_p95_ms"] <= 400   # 119 ms measured here (6.9 s before)
