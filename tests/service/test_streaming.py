"""The /ws protocol end to end (Starlette's test client, real renderer): frames arrive,
patches apply in order, acks bound frames in flight, latest wins under a slow reader,
errors keep the session, oversized messages close it with 1009."""

from __future__ import annotations

import io
import json
import time

import numpy as np
from PIL import Image

from fogbank.stream.protocol import HEADER
from fogbank.stream.session import PLAY_BUDGET_MS, REFINE_BUDGET_MS

VIEW = {"type": "view", "width": 96, "height": 64, "fps": 60, "quality": 80}


def frames_and_texts(ws, n_frames, ack=True, timeout=20.0):
    frames, texts = [], []
    t0 = time.monotonic()
    while len(frames) < n_frames and time.monotonic() - t0 < timeout:
        m = ws.receive()
        if m.get("bytes"):
            h = HEADER.unpack(m["bytes"][:HEADER.size])
            frames.append((h, m["bytes"][HEADER.size:]))
            if ack:
                ws.send_json({"type": "ack", "frame": h[1]})
        elif m.get("text"):
            import json
            texts.append(json.loads(m["text"]))
    return frames, texts


def open_ws(client, query=""):
    ws = client.websocket_connect("/ws" + (f"?{query}" if query else ""))
    return ws


def test_frames_arrive_with_header_and_jpeg(client):
    with open_ws(client, "camera.yaw=12") as ws:
        hello = ws.receive_json()
        assert hello["type"] == "hello" and hello["renderer"]
        assert (hello["refine_budget_ms"], hello["play_budget_ms"]) == (REFINE_BUDGET_MS, PLAY_BUDGET_MS)
        state = ws.receive_json()
        assert state["type"] == "state" and state["query"] == "v=1&camera.yaw=12"
        ws.send_json(VIEW)
        frames, _ = frames_and_texts(ws, 4)
        assert len(frames) == 4
        h, jpeg = frames[-1]
        assert h[0] == b"FBK1" and (h[6], h[7]) == (96, 64)
        assert np.asarray(Image.open(io.BytesIO(jpeg))).shape == (64, 96, 3)
        ids = [f[0][1] for f in frames]
        assert ids == sorted(ids)
        times = [f[0][3] for f in frames]
        assert times[-1] > times[0]            # playing: time runs


def test_patches_apply_in_order(client):
    with open_ws(client) as ws:
        ws.receive_json(), ws.receive_json()
        ws.send_json(VIEW)
        for d in (1.5, 2.0, 3.0):
            ws.send_json({"type": "params", "params": {"density": d}})
        versions = []
        while len(versions) < 3:
            m = ws.receive()
            if m.get("text"):
                import json
                s = json.loads(m["text"])
                versions.append((s["version"], s["params"]["density"]))
            elif m.get("bytes"):
                ws.send_json({"type": "ack", "frame": HEADER.unpack(m["bytes"][:36])[1]})
        assert [d for _, d in versions] == [1.5, 2.0, 3.0]
        assert [v for v, _ in versions] == sorted(v for v, _ in versions)
        frames, _ = frames_and_texts(ws, 3)
        assert frames[-1][0][2] == versions[-1][0]   # frames reflect the last version


def read_until(ws, last):
    """Read until a text message for which last(message) holds (a sentinel: the test client
    has no receive timeout). Returns frame headers and the states read, a last state with them."""
    frames, states = [], []
    while True:
        m = ws.receive()
        if m.get("bytes"):
            frames.append(HEADER.unpack(m["bytes"][:36]))
            continue
        t = json.loads(m["text"])
        if t["type"] == "state":
            states.append(t)
        if last(t):
            return frames, states


def read_until_speed(ws, speed):
    """Until the state that answers a speed message arrives."""
    return read_until(ws, lambda t: t["type"] == "state" and t["speed"] == speed)


def read_until_error(ws):
    """Until an error arrives."""
    return read_until(ws, lambda t: t["type"] == "error")


def test_acks_bound_frames_in_flight_and_latest_wins(client):
    with open_ws(client) as ws:
        ws.receive_json(), ws.receive_json()
        ws.send_json(VIEW)
        ws.send_json({"type": "play", "playing": False})
        # a slow reader: it never acknowledges, while the look keeps changing
        for d in np.linspace(1.0, 4.0, 12):
            ws.send_json({"type": "params", "params": {"density": float(d)}})
            time.sleep(0.03)
        got, early = [], []
        while len(got) < 2:   # two frames unacknowledged: the window is full
            m = ws.receive()
            if m.get("bytes"):
                got.append(HEADER.unpack(m["bytes"][:36]))
            elif json.loads(m["text"])["type"] == "state":
                early.append(json.loads(m["text"]))
        ws.send_json({"type": "speed", "speed": 1.5})
        # refused at once: a sentinel (the test client cannot time out), sent after the
        # speed; an error that answers no look change waits for nothing
        ws.send_json({"type": "view", **{k: v for k, v in VIEW.items() if k != "type"},
                      "show": "optical_depth", "layer": 9})
        more_frames, more_early = read_until_error(ws)
        got += more_frames
        early += more_early
        assert len(got) == 2                          # never more than two unacknowledged
        # the replies owed meanwhile wait for room in the window: none answers the speed yet
        assert [s for s in early if s["speed"] == 1.5] == []
        for h in got:
            ws.send_json({"type": "ack", "frame": h[1]})
        more, late = read_until_speed(ws, 1.5)
        states = early + late
        # ... and then collapse into one reply: every look change answered once, in fewer
        assert sum(s["answers"] for s in states) == 12
        assert len(late) == 1
        assert late[0]["params"]["density"] == 4.0
        final = late[0]["version"]
        seen = [h[2] for h in got + more]
        for h in more:
            ws.send_json({"type": "ack", "frame": h[1]})
        for _ in range(4):                            # a frame still being made may come first
            frames, _ = frames_and_texts(ws, 1)
            seen.append(frames[0][0][2])
            if seen[-1] == final:
                break
        assert seen[-1] == final                      # the latest look is shown ...
        assert len(set(seen)) <= 4                    # ... and most of the 12 were skipped


def test_errors_keep_the_session(client):
    import json
    with open_ws(client) as ws:
        ws.receive_json(), ws.receive_json()
        ws.send_json(VIEW)
        ws.send_text("{nope")
        ws.send_json({"type": "teleport"})
        ws.send_json({"type": "params", "params": {"layers": [{"kind": "cosine", "c0": 0.1}]}})
        ws.send_text('{"type": "params", "params": {"density": NaN}}')
        ws.send_bytes(b"\x00\x01binary junk")
        errors = []
        t0 = time.monotonic()
        while len(errors) < 5 and time.monotonic() - t0 < 20:
            m = ws.receive()
            if m.get("text"):
                t = json.loads(m["text"])
                if t["type"] == "error":
                    errors.append(t)
            elif m.get("bytes"):
                ws.send_json({"type": "ack", "frame": HEADER.unpack(m["bytes"][:36])[1]})
        msgs = [e["msg"] for e in errors]
        assert "malformed JSON" in msgs[0]
        assert "teleport" in msgs[1]
        assert errors[2]["detail"][0]["loc"][:2] == ["params", "layers"]
        assert errors[3]["detail"][0]["loc"][0] == "params"
        # still alive, with its last valid look
        ws.send_json({"type": "params", "params": {"density": 2.5}})
        ws.send_json({"type": "speed", "speed": 0.5})
        got, states = read_until_speed(ws, 0.5)
        for h in got:
            ws.send_json({"type": "ack", "frame": h[1]})
        assert states[-1]["params"]["density"] == 2.5
        frames, _ = frames_and_texts(ws, 4)      # up to two older frames may still arrive
        assert len(frames) == 4
        assert frames[-1][0][2] == states[-1]["version"]


def test_a_compact_link_opens_the_look_of_its_readable_query(client):
    from fogbank.model.params import FogParams
    from fogbank.model.urlstate import compact, decode
    q = "camera.yaw=33&density=1.7&layers=1&layers.0.kind=sphere&layers.0.radius=9&time=4&play=0&speed=2"
    with open_ws(client, compact(q)) as ws:
        assert ws.receive_json()["type"] == "hello"
        state = ws.receive_json()
    assert state["params"] == FogParams.model_validate(decode(q)[0]).model_dump(mode="json")
    assert (state["playing"], state["speed"]) == (False, 2.0)
    with open_ws(client, "z=garbage!") as ws:   # nothing readable: the session keeps its look
        ws.receive_json()
        error = ws.receive_json()
    assert error["type"] == "error" and error["detail"][0]["loc"] == ["query", "z"]


def test_oversized_message_closes_with_1009(client):
    with open_ws(client) as ws:
        ws.receive_json(), ws.receive_json()
        ws.send_text('{"type": "params", "params": {"x": "' + "a" * 70000 + '"}}')
        code = None
        for _ in range(50):
            m = ws.receive()
            if m["type"] == "websocket.close":
                code = m["code"]
                break
        assert code == 1009


def test_sessions_read_at_once_share_the_worker(client):
    """Three sessions, each read by its own thread for the same seconds, on the one
    interactive worker: each gets a fair share. A playing stream's queued frame once
    took every place its own frames freed, and a second session got no frame at all. A
    miss is measured once more (the shared machine's load can take one session's reader
    off its core for seconds); a starving scheduler misses both times."""
    for attempt in range(2):
        counts = _three_readers(client)
        print(f"\ntry {attempt + 1}: frames per session {counts}")
        if min(counts) >= 5 and min(counts) >= max(counts) // 2:
            break
    assert min(counts) >= 5
    assert min(counts) >= max(counts) // 2


def _three_readers(client) -> list[int]:
    """Frames each of three sessions, read at once by a thread each for 4 s, got."""
    import threading
    sockets = [open_ws(client) for _ in range(3)]
    counts = [0, 0, 0]
    with sockets[0] as a, sockets[1] as b, sockets[2] as c:
        for ws in (a, b, c):   # frames that cost more than 1/fps: the worker is never idle
            ws.receive_json(), ws.receive_json()
            ws.send_json({**VIEW, "width": 640, "height": 360, "fps": 120})
        frames_and_texts(a, 2)   # the worker warm and every session measured
        stop = time.monotonic() + 4.0

        def read(i, ws):
            while time.monotonic() < stop:
                m = ws.receive()
                if m.get("bytes"):
                    counts[i] += 1
                    ws.send_json({"type": "ack", "frame": HEADER.unpack(m["bytes"][:HEADER.size])[1]})
        threads = [threading.Thread(target=read, args=(i, ws)) for i, ws in enumerate((a, b, c))]
        for t in threads:
            t.start()
        for t in threads:
            t.join(30)
    return counts


def _decoded_video(frames, decoder):
    """Decode the video frames (codec byte 2: VP9) in order; [(header, RGB array)]."""
    import av
    out = []
    for h, data in frames:
        if h[11] != 2:
            continue
        for d in decoder.decode(av.Packet(data)):
            out.append((h, d.to_ndarray(format="rgb24")))
    return out


def test_video_frames_start_on_a_keyframe_and_a_new_size_gets_one(client):
    """Issue 34: with VP9 among the codecs a client decodes, frames drawn while time runs
    are VP9 packets; the first is a keyframe, as is the first at a new size, and every
    packet decodes (PyAV's decoder, apart from the encoder) in order."""
    import av
    from fogbank.stream.protocol import CODEC_IDS, FLAG_KEY
    with open_ws(client, "time=3") as ws:
        ws.receive_json(), ws.receive_json()
        ws.send_json({**VIEW, "width": 160, "height": 96, "codecs": ["vp09", "jpeg"]})
        frames, _ = frames_and_texts(ws, 6)
        video = [(h, d) for h, d in frames if h[11] == CODEC_IDS["vp09"]]
        assert len(video) >= 4
        assert video[0][0][9] & FLAG_KEY
        assert not any(h[9] & FLAG_KEY for h, _ in video[1:] if (h[6], h[7]) == (160, 96))
        decoded = _decoded_video(video, av.CodecContext.create("vp9", "r"))
        assert len(decoded) == len(video)
        assert decoded[-1][1].shape == (96, 160, 3)
        ws.send_json({**VIEW, "width": 128, "height": 80, "codecs": ["vp09", "jpeg"]})
        more, _ = frames_and_texts(ws, 8)
        resized = [(h, d) for h, d in more if h[11] == CODEC_IDS["vp09"] and (h[6], h[7]) == (128, 80)]
        assert resized and resized[0][0][9] & FLAG_KEY


def test_video_frames_are_as_close_to_the_stills_as_jpeg_q80_in_fewer_bytes(client):
    """The default look playing at 480x270: the VP9 frames' SSIM to the stills of their own
    times (GET /api/still.png, the reference) is no worse than the JPEG q80 frames', in at
    most a third of their bytes. Compared once the stream has settled: libvpx's realtime
    rate control starts a stream on a keyframe below its steady quality (SSIM 0.9897 here,
    JPEG q80 0.9906) and raises it over its first 10-20 frames (0.993 by the 20th); the
    16th frame, compared before, sat on the line (0.9903 in one CI run)."""
    import av
    from fogbank.tools.codecs import ssim

    def stream(codecs, n):
        with open_ws(client, "time=3") as ws:
            ws.receive_json(), ws.receive_json()
            ws.send_json({**VIEW, "width": 480, "height": 270, "codecs": codecs})
            frames, _ = frames_and_texts(ws, n)
        return frames

    def compared(h):
        # a full frame at the look's own quality and the view's size (a loaded machine's
        # refinement may reduce some, flag 4: the stream's choice, not the codec's)
        return (h[6], h[7]) == (480, 270) and h[9] & 1 and not h[9] & 4

    def still(t):
        r = client.get(f"/api/still.png?v=1&width=480&height=270&time={t!r}")
        return np.asarray(Image.open(io.BytesIO(r.content)).convert("RGB"))

    jpeg = [(h, d) for h, d in stream(["jpeg"], 12) if compared(h)][-4:]
    assert len(jpeg) == 4
    jpeg_ssim = [ssim(np.asarray(Image.open(io.BytesIO(d)).convert("RGB")), still(h[3])) for h, d in jpeg]
    video = [(h, d) for h, d in stream(["vp09", "jpeg"], 40) if h[11] == 2]
    decoded = [(h, img) for h, img in _decoded_video(video, av.CodecContext.create("vp9", "r")) if compared(h)]
    assert len(decoded) >= 4
    video_ssim = [ssim(img, still(h[3])) for h, img in decoded[-4:]]
    assert np.mean(video_ssim) >= np.mean(jpeg_ssim)
    # bytes a frame over the stream, its first keyframe included
    assert np.mean([len(d) for _, d in video]) <= np.mean([len(d) for _, d in jpeg]) / 3


def test_a_1080p_stream_in_vp9_decodes_to_the_stills_of_its_look(client):
    """Issue 34: video at 1080p in a stream (its encoders were measured at 1080p; no stream
    had sent it). The default look playing, asked at 1920x1080 in VP9: the stream starts
    small and grows to the view (each new size a keyframe); its packets, decoded in order by
    PyAV's own VP9 decoder, give one picture each at its header's size, and the last three
    at 1920x1080 are each within 30 dB PSNR of the still of the same look at the frame's
    own time (GET /api/still.png)."""
    import av

    from fogbank.stream.protocol import CODEC_IDS, FLAG_KEY
    with open_ws(client, "v=1&time=3") as ws:
        ws.receive_json(), ws.receive_json()   # hello, state
        ws.send_json({"type": "view", "width": 1920, "height": 1080, "fps": 30, "quality": 80,
                      "codecs": ["vp09", "jpeg"]})
        dec = av.CodecContext.create("vp9", "r")
        frames = []   # (header, decoded pictures)
        while sum((h[6], h[7]) == (1920, 1080) for h, _ in frames) < 3 and len(frames) < 300:
            m = ws.receive()
            if not m.get("bytes"):
                continue
            h = HEADER.unpack(m["bytes"][:HEADER.size])
            ws.send_json({"type": "ack", "frame": h[1]})
            assert h[11] == CODEC_IDS["vp09"]
            if not frames or (h[6], h[7]) != (frames[-1][0][6], frames[-1][0][7]):
                assert h[9] & FLAG_KEY   # the first frame, and each new size, stands alone
            frames.append((h, [f.to_ndarray(format="rgb24") for f in dec.decode(av.Packet(m["bytes"][HEADER.size:]))]))
    assert all(len(pics) == 1 and pics[0].shape == (h[7], h[6], 3) for h, pics in frames)
    full = [(h, pics[0]) for h, pics in frames if (h[6], h[7]) == (1920, 1080)][-3:]
    assert len(full) == 3
    for h, pic in full:
        r = client.get(f"/api/still.png?v=1&time={h[3]:.6f}&width=1920&height=1080")
        still = np.asarray(Image.open(io.BytesIO(r.content)).convert("RGB")).astype(float)
        psnr = 10 * np.log10(255.0 ** 2 / max(float(((pic.astype(float) - still) ** 2).mean()), 1e-9))
        print(f"\n1080p VP9 frame {h[1]} at {h[3]:.3f} s: PSNR {psnr:.1f} dB to the still")
        assert psnr >= 30.0
