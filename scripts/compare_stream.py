"""Delivered stream fps at 640x360 (still camera and orbiting) of an older checkout
against this one, alternating servers in one run (this machine is noisy: compare ratios
measured together). Usage, from the repo root:

    git worktree add /tmp/before 7e5bbdb
    .venv/bin/python scripts/compare_stream.py /tmp/before/server [rounds] [seconds]

Each server is started on 127.0.0.1 and stopped by its PID; the old one runs with
PYTHONPATH pointing at its `server/` folder."""

from __future__ import annotations

import asyncio
import os
import socket
import statistics
import subprocess
import sys
import time
import urllib.request

from fogbank.bench_stream import delivered_fps


def start(pythonpath: str | None, env: dict) -> tuple[subprocess.Popen, str]:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    e = {**os.environ, "FOGBANK_MAX_SESSIONS_PER_CLIENT": "1000", **env}
    if pythonpath:
        e["PYTHONPATH"] = pythonpath
    p = subprocess.Popen([sys.executable, "-m", "fogbank.cli", "serve", "--host", "127.0.0.1", "--port", str(port)],
                         env=e, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    url = f"http://127.0.0.1:{port}"
    for _ in range(600):
        try:
            urllib.request.urlopen(url + "/healthz", timeout=1)
            break
        except OSError:
            time.sleep(0.2)
    return p, url


def main() -> None:
    old = sys.argv[1]
    rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    seconds = float(sys.argv[3]) if len(sys.argv) > 3 else 15.0
    configs = [("before", old, {}), ("after, 1 frame per worker", None, {"FOGBANK_FRAMES_PER_WORKER": "1"}),
               ("after, 2 frames per worker", None, {"FOGBANK_FRAMES_PER_WORKER": "2"})]
    res: dict = {}
    for rnd in range(rounds):
        for name, pp, env in configs:
            p, url = start(pp, env)
            try:
                ws = url.replace("http", "ws", 1)
                asyncio.run(delivered_fps(ws, "v=1", 640, 360, seconds=3))   # warm
                for orbit in (False, True):
                    r = asyncio.run(delivered_fps(ws, "v=1", 640, 360, seconds=seconds, orbit=orbit))
                    res.setdefault((name, orbit), []).append(r["fps"])
                    print(f"round {rnd} {name:28s} {'orbit' if orbit else 'still'} {r['fps']:6.1f} fps", flush=True)
            finally:
                p.terminate()
                p.wait(60)
    for orbit in (False, True):
        base = statistics.median(res[("before", orbit)])
        for name, _, _ in configs:
            m = statistics.median(res[(name, orbit)])
            print(f"{'orbit' if orbit else 'still'} {name:28s} median {m:6.1f} fps  ({m / base:.2f}x before)")


if __name__ == "__main__":
    main()
