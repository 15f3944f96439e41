"""`fogbank soak`: N streaming clients for a while against one server; frames per client,
errors, and the memory of the server's whole process tree (web process and render
workers) over time. Pass: after warm-up memory grows no more than 10%, every client
receives frames in every window, no error in the server's log.

Churn mode: every client changes its look (density, wind, camera, a layer) and its view
size (one of five window sizes) every second, which is what grew memory without bound
when render targets leaked on cache eviction."""

from __future__ import annotations

import asyncio
import json
import random
import statistics
import time
from pathlib import Path

import websockets

from fogbank.stream.protocol import HEADER

WINDOW_S = 10.0
CHURN_SIZES = [(640, 360), (800, 450), (960, 540), (1024, 576), (1280, 720)]
CHURN_LAYERS = [{"kind": "height"}, {"kind": "sphere"}, {"kind": "homogeneous", "density": 0.004},
                {"kind": "cosine"}, {"kind": "noise"}, {"kind": "potential"}]


def _churn(rng: random.Random) -> list[dict]:
    """The messages of one churn step: a new look (its sun too) and a new view size."""
    w, h = rng.choice(CHURN_SIZES)
    look = {"density": round(rng.uniform(0.5, 2.0), 3),
            "wind": {"speed": round(rng.uniform(0, 8), 2), "direction": round(rng.uniform(0, 360), 1)},
            "camera": {"yaw": round(rng.uniform(-60, 60), 2), "pitch": round(rng.uniform(-15, 5), 2)},
            # a sun of its own: the worker's shadow maps by sun, and the previews' (render/resources.py)
            "sun": {"azimuth": round(rng.uniform(0, 360), 1), "elevation": round(rng.uniform(5, 80), 1)},
            "layers": [rng.choice(CHURN_LAYERS) for _ in range(rng.randint(1, 3))]}
    return [{"type": "params", "params": look},
            {"type": "view", "width": w, "height": h, "fps": 30}]


async def _client(url: str, i: int, seconds: float, stats: dict, churn: bool = False,
                  codecs: tuple[str, ...] = ("jpeg",)) -> None:
    rng = random.Random(i)
    frames, errors, windows, video = 0, 0, set(), 0
    t0 = time.monotonic()
    try:
        async with websockets.connect(f"{url}/ws?v=1&camera.yaw={rng.uniform(-40, 40):.1f}",
                                      max_size=None) as ws:
            await ws.recv()
            await ws.recv()
            await ws.send(json.dumps({"type": "view", "width": 640, "height": 360, "fps": 30, "codecs": list(codecs)}))
            next_move = t0 + 1.0
            while (now := time.monotonic()) - t0 < seconds:
                try:
                    m = await asyncio.wait_for(ws.recv(), 5)
                except asyncio.TimeoutError:
                    continue
                if isinstance(m, bytes):
                    frames += 1
                    video += HEADER.unpack(m[:HEADER.size])[11] != 0   # codec 0: JPEG
                    windows.add(int((now - t0) // WINDOW_S))
                    await ws.send(json.dumps({"type": "ack", "frame": HEADER.unpack(m[:HEADER.size])[1]}))
                elif json.loads(m).get("type") == "error":
                    errors += 1
                if now >= next_move and churn:   # a new look and view size every second
                    next_move = now + 1.0
                    for msg in _churn(rng):
                        await ws.send(json.dumps({**msg, "codecs": list(codecs)} if msg["type"] == "view" else msg))
                elif now >= next_move:   # a user nudging the view now and then
                    next_move = now + rng.uniform(1, 4)
                    await ws.send(json.dumps({"type": "camera", "camera": {"yaw": rng.uniform(-60, 60)}}))
    except Exception as exc:  # noqa: BLE001 - a dropped client is a failure to report
        stats.setdefault("exceptions", []).append(f"client {i}: {type(exc).__name__}: {exc}")
    stats[i] = {"frames": frames, "video_frames": video, "errors": errors, "windows": sorted(windows)}


async def _memory(rss, seconds: float, samples: list) -> None:
    t0 = time.monotonic()
    while time.monotonic() - t0 < seconds:
        samples.append((round(time.monotonic() - t0, 1), rss()))
        await asyncio.sleep(2.0)


async def _run(url: str, clients: int, seconds: float, rss, churn: bool, codecs: tuple[str, ...]) -> dict:
    stats: dict = {}
    samples: list = []
    await asyncio.gather(_memory(rss, seconds, samples),
                         *[_client(url, i, seconds, stats, churn, codecs) for i in range(clients)])
    return {"stats": stats, "memory": samples}


def run(url: str, rss, clients: int = 8, seconds: float = 600.0, log_text=lambda: "",
        churn: bool = False, codecs: tuple[str, ...] = ("jpeg",)) -> dict:
    """`codecs`: what each client says it decodes (its view messages): ("vp09", "jpeg")
    makes the frames drawn while time runs VP9, each session with its own encoder."""
    res = asyncio.run(_run(url.replace("http", "ws", 1), clients, seconds, rss, churn, codecs))
    per = [res["stats"][i] for i in range(clients) if i in res["stats"]]
    windows = int(seconds // WINDOW_S)
    mem = [m for _, m in res["memory"]]
    # the first fifth is warm-up. Growth compares the median of the last fifth with the
    # median of the second: caches at their byte budgets make memory swing by tens of MB
    # between samples, which a single sample as the baseline would read as growth.
    fifth = max(1, len(mem) // 5)
    base = statistics.median(mem[fifth:2 * fifth]) if len(mem) >= 2 * fifth else (mem[-1] if mem else 0.0)
    last = statistics.median(mem[-fifth:]) if mem else 0.0
    growth = (last - base) / base if base else 0.0
    peak = (max(mem[fifth:]) - base) / base if base and len(mem) > fifth else 0.0
    log = log_text()
    bad_log = [line for line in log.splitlines()
               if '"level": "error"' in line or "Traceback" in line or "Exception" in line]
    out = {"clients": clients, "seconds": seconds, "churn": churn, "codecs": list(codecs),
           "frames_per_client": [p["frames"] for p in per],
           "video_frames_per_client": [p["video_frames"] for p in per],
           "errors": sum(p["errors"] for p in per) + len(res["stats"].get("exceptions", [])),
           "client_exceptions": res["stats"].get("exceptions", []),
           "every_client_every_window": all(len(p["windows"]) >= windows - 1 for p in per) and len(per) == clients,
           "memory_mb": res["memory"], "memory_growth_after_warmup": growth,
           "memory_peak_over_baseline": peak,
           "log_errors": bad_log[:20]}
    out["ok"] = (out["errors"] == 0 and out["every_client_every_window"] and growth <= 0.10 and not bad_log)
    return out


def report(res: dict) -> str:
    mem = res["memory_mb"]
    lines = [f"soak: {res['clients']} clients x {res['seconds']:.0f} s"
             + (" (churn: look and view size change every second)" if res.get("churn") else "")
             + f", decoding {','.join(res.get('codecs', ['jpeg']))}",
             f"  frames per client: {res['frames_per_client']}",
             f"  video frames per client: {res.get('video_frames_per_client')}",
             f"  errors: {res['errors']}  every client in every {WINDOW_S:.0f} s window: "
             f"{res['every_client_every_window']}",
             f"  process tree RSS MB: start {mem[0][1]:.0f}, end {mem[-1][1]:.0f}, max {max(m for _, m in mem):.0f}; "
             f"growth after warm-up (median of the last fifth over the second) "
             f"{res['memory_growth_after_warmup'] * 100:.1f}%, peak {res['memory_peak_over_baseline'] * 100:.1f}% "
             "over that baseline",
             f"  server log errors: {len(res['log_errors'])}", f"  {'PASS' if res['ok'] else 'FAIL'}"]
    return "\n".join(lines)


def write(res: dict, path: str) -> None:
    Path(path).write_text(json.dumps(res, indent=1))
