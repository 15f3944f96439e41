"""Re-measure issue 8's findings on an older checkout and on this one, in one run:
process-tree memory over 20 stills of different sizes, /healthz and a small still while a
heavy still renders, a transmittance request over 16 times, a 100 MB body, a 5000-message
flood. Usage, from the repo root:

    git worktree add /tmp/before 7e5bbdb
    .venv/bin/python scripts/issue8_findings.py /tmp/before/server
"""
import asyncio, json, sys, threading, time, urllib.request, urllib.error, http.client
from pathlib import Path
sys.path.insert(0, str(Path(__file__).parent))
from compare_stream import start
from fogbank.workers import proctree
import websockets

MB = 2**20
def tree(srv): return round(proctree.tree_rss_bytes(srv.proc.pid) / MB)

def get(url, timeout=120):
    t0 = time.monotonic()
    try:
        with urllib.request.urlopen(url, timeout=timeout) as r: r.read(); return r.status, time.monotonic() - t0
    except urllib.error.HTTPError as e: return e.code, time.monotonic() - t0

def post(url, body, timeout=300):
    t0 = time.monotonic()
    req = urllib.request.Request(url, data=json.dumps(body).encode(), headers={"Content-Type": "application/json"})
    try:
        with urllib.request.urlopen(req, timeout=timeout) as r: r.read(); return r.status, time.monotonic() - t0
    except urllib.error.HTTPError as e: return e.code, time.monotonic() - t0

def leak(p, url):
    get(url + "/api/still.jpg?width=1280&height=720")
    w0 = tree(p)
    for w in range(1280, 1300): get(url + f"/api/still.jpg?width={w}&height=720")
    return {"warm_mb": w0, "after_20_stills_mb": tree(p)}

def freeze(url):
    body = {"width": 1920, "height": 1080, "layers": [{"kind": "noise", "mode": "volume", "samples": 128}] * 2}
    out = {}
    t = threading.Thread(target=lambda: out.update(heavy=post(url + "/api/still?format=png", body)))
    t.start(); time.sleep(0.5)
    h = [get(url + "/healthz")[1] for _ in range(5)]
    small = get(url + "/api/still.jpg?width=320&height=180&time=3")
    t.join()
    return {"heavy_status_s": [out["heavy"][0], round(out["heavy"][1], 1)], "healthz_max_s": round(max(h), 3),
            "small_still_s": round(small[1], 2), "small_status": small[0]}

def transmittance(url):
    ray = {"origin": [0, 5, 0], "direction": [1, 0, 0], "length": 100}
    body = {"params": {"layers": [{"kind": "particles", "count": 1024}]}, "rays": [dict(ray, time=float(t)) for t in range(16)]}
    s, dt = post(url + "/api/transmittance", body)
    return {"16_times_1024_particles": [s, round(dt, 2)]}

def body100(p, url):
    r0 = tree(p)
    t0 = time.monotonic()
    c = http.client.HTTPConnection("127.0.0.1", int(url.rsplit(":", 1)[1]), timeout=120)
    try:
        c.putrequest("POST", "/api/still"); c.putheader("Content-Type", "application/json")
        c.putheader("Content-Length", str(100 * MB)); c.endheaders()
        chunk = b" " * MB
        status = None
        for _ in range(100):
            try: c.send(chunk)
            except (BrokenPipeError, ConnectionResetError): break
        try: status = c.getresponse().status
        except Exception as e: status = type(e).__name__
    finally: c.close()
    return {"status": status, "s": round(time.monotonic() - t0, 2), "tree_mb_before": r0, "tree_mb_after": tree(p)}

async def flood(url):
    async with websockets.connect(url.replace("http", "ws", 1) + "/ws?play=0", max_size=None) as ws:
        await ws.recv(); await ws.recv()
        for _ in range(5000): await ws.send(json.dumps({"type": "speed", "speed": 1.0}))
        n = 0
        try:
            while True:
                m = await asyncio.wait_for(ws.recv(), 3)
                if isinstance(m, str) and "messages/s" in m: n += 1
        except (asyncio.TimeoutError, websockets.ConnectionClosed): pass
        return n

if __name__ == "__main__":
    for name, pp in (("before", sys.argv[1]), ("after", None)):
        srv = start(pp, {})
        p, url = srv, srv.url
        try:
            res = {"leak": leak(p, url), "freeze": freeze(url), "transmittance": transmittance(url),
                   "body_100mb": body100(p, url), "flood_5000_error_replies": asyncio.run(flood(url))}
            print(name, json.dumps(res), flush=True)
        finally:
            srv.stop()
