"""The `fogbank` command: serve, still, gallery."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path


def _still_params(args):
    from pydantic import ValidationError

    from fogbank.model.params import StillParams
    from fogbank.model.urlstate import URLError, decode
    query = "&".join(args.params)
    if args.preset:
        query = f"preset={args.preset}" + (f"&{query}" if query else "")
    try:
        value, _ = decode(query, StillParams)
        return StillParams.model_validate(value)
    except URLError as exc:
        sys.exit(f"fogbank still: {exc}")
    except ValidationError as exc:
        sys.exit("fogbank still: " + "; ".join(
            f"{'.'.join(map(str, e['loc']))}: {e['msg']}" for e in exc.errors()))


def cmd_serve(args) -> None:
    import os

    import uvicorn

    from fogbank.service import logs
    from fogbank.service.api import create_app
    from fogbank.service.limits import MAX_HEAD_BYTES, json_h11_protocol
    from fogbank.stream.protocol import MAX_MESSAGE
    from fogbank.settings import get_settings
    logs.setup()
    base = get_settings()
    settings = base.model_copy(update={"host": args.host or base.host, "port": args.port or base.port})
    app = create_app(settings)
    # h11 bounds the bytes it buffers for a request head (httptools does not); the app's
    # RequestLimits answers below that bound (JSON; a page for a link opened in a browser).
    # A WebSocket message is refused by the protocol past twice MAX_MESSAGE, by the app
    # (1009, with a reason) past MAX_MESSAGE.
    # websockets reads a WebSocket request line of at most 8192 bytes (a /ws link of a
    # long look got a plain-text 400, and the page a black view); let the app's own limit
    # answer instead. websockets' reader still ends a line at 32 KiB. Read on import,
    # which uvicorn does when it starts.
    os.environ.setdefault("WEBSOCKETS_MAX_LINE_LENGTH", str(MAX_HEAD_BYTES))
    # No permessage-deflate, which browsers offer and uvicorn accepted: the stream's frames
    # are JPEG, which deflate does not shrink, and compressing each 1280x720 frame took the
    # web process 0.84 ms of CPU (cProfile, 374 frames), on the cores that render.
    config = uvicorn.Config(app, host=settings.host, port=settings.port, log_config=None,
                            http=json_h11_protocol(settings.max_url_bytes, settings.head_timeout_s,
                                                   settings.body_timeout_s),
                            h11_max_incomplete_event_size=MAX_HEAD_BYTES, ws="websockets",
                            ws_per_message_deflate=False,
                            ws_max_size=2 * MAX_MESSAGE, timeout_graceful_shutdown=20,
                            timeout_keep_alive=15, proxy_headers=True,
                            forwarded_allow_ips=settings.forwarded_allow_ips)

    class Server(uvicorn.Server):
        def handle_exit(self, sig, frame):   # readiness turns to "draining" at once
            app.state.drain()
            super().handle_exit(sig, frame)
    Server(config).run()


def cmd_still(args) -> None:
    from fogbank.render.encode import encode
    from fogbank.render.renderer import Renderer, create_context
    from fogbank.settings import get_settings
    still = _still_params(args)
    fmt = {"jpeg": "jpg"}.get(Path(args.out).suffix.lower().lstrip("."), Path(args.out).suffix.lower().lstrip("."))
    if fmt not in ("png", "jpg", "webp"):
        sys.exit(f"fogbank still: --out must end in .png, .jpg or .webp, not {args.out!r}")
    s = get_settings()
    r = Renderer(create_context(s.gl_backend, s.gl_device, s.raster_threads))
    img = r.render(still)
    Path(args.out).write_bytes(encode(img, fmt))
    print(f"{args.out}: {still.width}x{still.height} on {r.info()['renderer']}")


GALLERY_LATER_S = 8.0   # the gallery's second frame of each preset, this much later


def cmd_gallery(args) -> None:
    """Render every preset at --width x --height as JPEG at its time and GALLERY_LATER_S
    later (NAME.jpg, NAME-later.jpg), timing each (median of --repeat), and a contact sheet
    of them all (contact-sheet.jpg, each preset's two frames side by side, named)."""
    import numpy as np
    from PIL import Image, ImageDraw

    from fogbank.render.encode import encode
    from fogbank.model.params import StillParams
    from fogbank.model.presets import preset_dict, presets
    from fogbank.render.renderer import Renderer, create_context
    from fogbank.settings import get_settings
    s = get_settings()
    r = Renderer(create_context(s.gl_backend, s.gl_device, s.raster_threads))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows, sheet = [], []
    thumb = args.thumb if args.thumb and args.thumb < args.width else args.width
    size = (thumb, round(thumb * args.height / args.width))
    for name in presets():
        still = StillParams.model_validate({**preset_dict(name), "width": args.width, "height": args.height})
        r.render(still)  # warm: meshes, programs, targets
        times = []
        for i in range(args.repeat):
            # a new time each run, so the scene pass is cached but the fog is recomputed
            cold = still.model_copy(update={"camera": still.camera.model_copy(
                update={"yaw": still.camera.yaw + 1e-3 * (i + 1)})})
            t0 = time.perf_counter()
            r.render(cold)
            times.append(time.perf_counter() - t0)
        pair = []
        for suffix, t in (("", still.time), ("-later", still.time + GALLERY_LATER_S)):
            img = Image.fromarray(r.render(still.model_copy(update={"time": t})))
            if size != img.size:   # small JPEGs for the README
                img = img.resize(size, Image.LANCZOS)
            (out / f"{name}{suffix}.jpg").write_bytes(encode(np.asarray(img), "jpg", quality=82))
            pair.append(img)
        sheet.append((name, still.time, pair))
        med = sorted(times)[len(times) // 2]
        rows.append({"preset": name, "ms": round(med * 1000, 1)})
        print(f"{name:18s} {med * 1000:8.1f} ms  (median of {args.repeat}, {args.width}x{args.height}, "
              f"full frame incl. scene pass and readback)")
    w, h = size[0] // 2, size[1] // 2
    contact = Image.new("RGB", (4 * w, -(-len(sheet) // 2) * h), (0, 0, 0))
    for k, (name, t, pair) in enumerate(sheet):
        for j, img in enumerate(pair):
            x, y = (2 * (k % 2) + j) * w, (k // 2) * h
            contact.paste(img.resize((w, h), Image.LANCZOS), (x, y))
            ImageDraw.Draw(contact).text((x + 4, y + 3), f"{name}  t = {t + j * GALLERY_LATER_S:g} s", fill=(255, 255, 0))
    (out / "contact-sheet.jpg").write_bytes(encode(np.asarray(contact), "jpg", quality=85))
    print(json.dumps({"renderer": r.info()["renderer"], "results": rows}))


def cmd_bench_stream(args) -> None:
    """Delivered fps and control-to-frame latency against a server (started here unless
    --url is given)."""
    from fogbank.tools.bench_stream import run
    from fogbank.tools.child import ChildServer
    srv = None if args.url else ChildServer()
    try:
        rows = run((args.url or srv.url).replace("http", "ws", 1), args.query)
        print(json.dumps(rows))
    finally:
        if srv:
            srv.stop()


def cmd_bench_codecs(args) -> None:
    """Video codecs on fogbank's own frames (tools/codecs.py)."""
    from fogbank.tools.codecs import run
    run(args.frames, args.out)


def cmd_bench_link(args) -> None:
    """The stream through a thin link, this code and, with --before-tree, another's."""
    from fogbank.tools.link import bench
    bench(args.before_tree, args.seconds, args.out)


def cmd_bench_live(args) -> None:
    """Viewers of one live session: their frame rates, the renders, the server's CPU."""
    from fogbank.tools.audience import bench
    bench(tuple(args.viewers), args.seconds, args.out)


def cmd_bench(args) -> None:
    from fogbank.tools.bench import run
    run(args.out, quick=args.quick, only_targets=args.targets_only, before=args.before,
        before_tree=args.before_tree, only_lit=args.lit_only)


def cmd_soak(args) -> None:
    """Soak a server started here (so that its memory and log can be read)."""
    from fogbank.tools import soak
    from fogbank.tools.child import ChildServer
    srv = ChildServer()
    try:
        res = soak.run(srv.url, srv.rss_mb, args.clients, args.seconds, srv.log_text, churn=args.churn,
                       codecs=tuple(args.codecs.split(",")))
    finally:
        srv.stop()
    print(soak.report(res))
    if args.out:
        soak.write(res, args.out)
    sys.exit(0 if res["ok"] else 1)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(prog="fogbank", description="Analytic fog, rendered on the server.")
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("serve", help="run the web service")
    p.add_argument("--host", help="default: FOGBANK_HOST or 127.0.0.1")
    p.add_argument("--port", type=int, help="default: FOGBANK_PORT or 8000")
    p.set_defaults(fn=cmd_serve)
    p = sub.add_parser("still", help="render one still to a file",
                       description="params are URL fields: fogbank still --out a.png width=640 camera.yaw=20")
    p.add_argument("--out", required=True, help="FILE.png, FILE.jpg or FILE.webp")
    p.add_argument("--preset", help="start from this preset instead of the default")
    p.add_argument("params", nargs="*", help="key=value fields, as in the page URL")
    p.set_defaults(fn=cmd_still)
    p = sub.add_parser("gallery", help="render and time every preset")
    p.add_argument("--out", default="docs/gallery")
    p.add_argument("--width", type=int, default=1280)
    p.add_argument("--height", type=int, default=720)
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--thumb", type=int, default=640, help="width of the saved JPEGs (0 = full)")
    p.set_defaults(fn=cmd_gallery)
    p = sub.add_parser("bench", help="the whole benchmark; writes docs/bench.md and .json")
    p.add_argument("--out", default="docs")
    p.add_argument("--quick", action="store_true", help="shorter runs (a smoke test)")
    p.add_argument("--targets-only", action="store_true",
                   help="measure issue 13's targets only (and the analytic/raymarch section); writes bench.json")
    p.add_argument("--before", help="a bench.json of another version: its targets become the 'before' column")
    p.add_argument("--before-tree", help="another checkout's server/ folder: its server is run in turn with this "
                   "one's in each round of the delivered frame rates (the 'before' column for them)")
    p.add_argument("--lit-only", action="store_true",
                   help="the still camera's 720p frame by light (lit, its grid lowered, unlit; with --before-tree "
                   "the earlier code's too, in turn); writes bench-lit.json")
    p.set_defaults(fn=cmd_bench)
    p = sub.add_parser("soak", help="N streaming clients for a while; memory, frames, errors")
    p.add_argument("--clients", type=int, default=8)
    p.add_argument("--seconds", type=float, default=600.0)
    p.add_argument("--out", help="write the results as JSON here")
    p.add_argument("--churn", action="store_true", help="each client changes look and view size every second")
    p.add_argument("--codecs", default="jpeg", help="what the clients decode, most wanted first (vp09,jpeg: "
                                                     "video frames while time runs)")
    p.set_defaults(fn=cmd_soak)
    p = sub.add_parser("bench-link", help="the stream through a thin link (a loopback relay: 5, 2, 1 Mbit/s)")
    p.add_argument("--before-tree", help="another checkout's server/ folder, run in turn with this code")
    p.add_argument("--seconds", type=float, default=8.0)
    p.add_argument("--out", default="docs/bench-link.md")
    p.set_defaults(fn=cmd_bench_link)

    p = sub.add_parser("bench-live", help="viewers of one live session: their fps, the renders, the server's CPU")
    p.add_argument("--viewers", type=int, nargs="+", default=[0, 1, 5, 10, 20])
    p.add_argument("--seconds", type=float, default=8.0)
    p.add_argument("--out", default="docs/bench-live.md")
    p.set_defaults(fn=cmd_bench_live)

    p = sub.add_parser("bench-codecs", help="JPEG, VP8, VP9 and AV1 on fogbank's frames: bytes, ms, SSIM")
    p.add_argument("--frames", type=int, default=60)
    p.add_argument("--out", default="docs/bench-codecs.md")
    p.set_defaults(fn=cmd_bench_codecs)

    p = sub.add_parser("bench-stream", help="delivered fps and control latency over /ws")
    p.add_argument("--url", help="a running server (default: start one on a free port)")
    p.add_argument("--query", default="v=1", help="the look to stream")
    p.set_defaults(fn=cmd_bench_stream)
    args = ap.parse_args(argv)
    args.fn(args)


if __name__ == "__main__":
    main()
