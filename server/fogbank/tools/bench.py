"""`fogbank bench`: fogbank against the seeds' tables, against raymarching, and against
its own limits. Writes docs/bench.md and docs/bench.json.

The machine is shared and noisy: every number is a median of repeats, and every
comparison is a ratio of two things timed in the same run.
"""

from __future__ import annotations

import asyncio
import inspect
import json
import os
import platform
import statistics
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import numpy as np

from fogbank.model import presets as P
from fogbank.tools.child import ChildServer
from fogbank.render.encode import encode
from fogbank.model.params import FogParams, StillParams
from fogbank.kinds.homogeneous import Homogeneous
from fogbank.render.probes import fog_only
from fogbank.render.renderer import Renderer, create_context

TOL = 1.0 / 255.0


def _median(f, n: int) -> float:
    return statistics.median(f(i) for i in range(n))


def _still(preset: str, w: int, h: int, **update) -> StillParams:
    return StillParams.model_validate({**P.preset_dict(preset), "width": w, "height": h, **update})


def _cpu() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip() + f" ({os.cpu_count()} cores)"
    except OSError:
        pass
    return platform.processor() or platform.machine()


# ---------------------------------------------------------------- 1: analytic vs raymarched


def _kind_looks() -> dict[str, StillParams]:
    """One representative layer per exponential kind, from the presets, default camera,
    with the fog toward the sun and the light shafts off: the raymarch integrates the view
    ray's transmittance only (render/programs.py fog), so the analytic pass is timed doing
    that work and no more (with them on, it also integrated every layer toward the sun,
    and both paid the shafts' shadow-map samples)."""
    def first(preset, kind):
        return next(l for l in FogParams.model_validate(P.preset_dict(preset)).layers if l.kind == kind)
    layers = {
        "homogeneous": Homogeneous(density=0.01),
        "height": first("default", "height"),
        "cosine": first("biri-fig6", "cosine"),
        "polynomial": first("biri-fig7", "polynomial"),
        "potential": first("biri-fig8", "potential"),
        "sphere": first("quilez-spheres", "sphere"),
    }
    effects = {**P.preset_dict("default")["effects"], "sun_through_fog": False, "shafts": 0.0}
    return {k: _still("default", 1280, 720, layers=[l.model_dump()], time=3.0, effects=effects)
            for k, l in layers.items()}


def _reference(still: StillParams, invd: np.ndarray, view) -> np.ndarray:
    """Float64 raw transmittance of every fog texel (scale 1), by the numpy closed forms."""
    from fogbank.kinds.reference import layer_transmittance
    h, w = invd.shape
    py, px = np.mgrid[0:h, 0:w]
    dirs = view.ray(px.ravel(), py.ravel(), w, h)
    d = np.where(invd.ravel() > 0, 1.0 / np.maximum(invd.ravel(), 1e-30), still.effects.sky_distance)
    O = np.broadcast_to(view.eye, dirs.shape)
    t = np.full(len(d), still.time)
    T = np.ones(len(d))
    for layer in still.layers:
        T *= layer_transmittance(layer, still, O, dirs, d, t)
    return T.reshape(h, w)


def _versus(r: Renderer, still: StillParams, repeat: int, max_steps: int) -> dict:
    """One look's analytic fog pass against the raymarch with the fewest steps (powers of
    two, then bisected) whose max |T - T_ref| over the frame is within TOL: ms of each
    (medians, alternated), their errors and the steps."""
    _, T_an, invd, view = fog_only(r, still)
    ref = _reference(still, invd.astype(np.float64), view)
    err_an = float(np.abs(T_an - ref).max())

    def err_at(n):
        _, T_rm, _, _ = fog_only(r, still, raymarch_steps=n)
        return float(np.abs(T_rm - ref).max())
    n, errs = 1, {}
    while n <= max_steps:
        errs[n] = err_at(n)
        if errs[n] <= TOL:
            break
        n *= 2
    if n > max_steps:
        steps = None
    else:
        lo, hi = n // 2, n
        while hi - lo > 1 and lo >= 1:
            mid = (lo + hi) // 2
            errs[mid] = err_at(mid)
            lo, hi = (lo, mid) if errs[mid] <= TOL else (mid, hi)
        steps = hi
    use = steps or max_steps
    fog_only(r, still, raymarch_steps=use, read=False)   # compile outside the timing
    an, rm = [], []
    for i in range(repeat):   # alternate, so that drift in the machine's load cancels
        s = still.model_copy(update={"time": 3.0 + i})
        an.append(fog_only(r, s, read=False))
        rm.append(fog_only(r, s, raymarch_steps=use, read=False))
    t_an, t_rm = statistics.median(an), statistics.median(rm)
    return {"analytic_ms": t_an, "analytic_max_err": err_an, "raymarch_steps": steps,
            "raymarch_max_err": errs.get(use), "raymarch_ms": t_rm, "speedup": t_rm / t_an}


def analytic_vs_raymarch(r: Renderer, repeat: int = 9, max_steps: int = 2048) -> list[dict]:
    rows = []
    for kind, still in _kind_looks().items():
        row = {"kind": kind, **_versus(r, still, repeat, max_steps)}
        rows.append(row)
        steps, use = row["raymarch_steps"], row["raymarch_steps"] or max_steps
        print(f"  {kind:12s} analytic {row['analytic_ms']:7.1f} ms (max|dT| {row['analytic_max_err']:.1e})  raymarch "
              f"{'>' if steps is None else ''}{use:5d} steps {row['raymarch_ms']:8.1f} ms  x{row['speedup']:.1f}")
    return rows


# ---------------------------------------------------------------- 2: Biri Table 1

BIRI_TABLE1 = {"Polynomials": {"512x512": 3.5, "512x256": 6.7, "256x256": 12.5, "256x128": 20, "128x128": 30},
               "Constant": {"512x512": 6.6, "512x256": 11.5, "256x256": 20, "256x128": 30, "128x128": 40}}


def biri_table1(r: Renderer, repeat: int = 5) -> list[dict]:
    """800x600 frames (scene pass redrawn each frame, as in the paper), fog at 1, 1/2,
    1/4 scale (800x600, 400x300, 200x150 fog texels), polynomial fog (figure 7's two
    polynomials) against constant fog."""
    poly = FogParams.model_validate(P.preset_dict("biri-fig7")).layers
    rows = []
    for name, layers in (("Polynomials", [l.model_dump() for l in poly]),
                         ("Constant", [Homogeneous(density=0.01).model_dump()])):
        for scale in (1, 2, 4):
            still = _still("default", 800, 600, layers=layers, effects={"fog_scale": scale})
            r.render(still)

            def frame(i):
                s = still.model_copy(update={"camera": still.camera.model_copy(
                    update={"yaw": still.camera.yaw + 0.01 * (i + 1)})})
                t0 = time.perf_counter()
                r.render(s, lend=True)
                return time.perf_counter() - t0
            fps = 1.0 / _median(frame, repeat)
            size = f"{-(-800 // scale)}x{-(-600 // scale)}"
            rows.append({"fog": name, "fog_texture": size, "fps": fps})
            print(f"  {name:11s} fog texture {size:8s} {fps:6.1f} fps")
    return rows


# ---------------------------------------------------------------- 3: Gawron Tables 2 and 3


def gawron(r: Renderer, repeat: int = 7) -> dict:
    """1920x1080: the fog pass alone, fog + blur fused (single pass), fog + blur as
    separate passes; ms each, GPU work timed with glFinish around the passes."""
    out = {}
    for mode in ("off", "single", "separate"):
        still = _still("gawron-distance", 1920, 1080, effects={
            **P.preset_dict("gawron-distance")["effects"], "blur": mode})
        r.render(still)

        def once(i):
            s = still.model_copy(update={"time": still.time + i + 1})
            r.ctx.finish()
            t0 = time.perf_counter()
            r.render(s, lend=True)   # scene pass cached: fog pass, composite, blur, readback
            r.ctx.finish()
            return (time.perf_counter() - t0) * 1000
        out[mode] = _median(once, repeat)
    read_ms = _median(lambda i: _timed(lambda: r.caches.targets(1920, 1080).read_image()), repeat)
    res = {"fog_ms": out["off"] - read_ms, "single_ms": out["single"] - read_ms,
           "separate_ms": out["separate"] - read_ms, "readback_ms": read_ms}
    res["single_over_separate"] = res["single_ms"] / res["separate_ms"]
    print(f"  fog {res['fog_ms']:.1f} ms, fog+blur single {res['single_ms']:.1f} ms, separate "
          f"{res['separate_ms']:.1f} ms, single/separate {res['single_over_separate']:.2f} "
          f"(paper: 0.20, 0.44, 0.65 ms; 0.68)")
    return res


# ---------------------------------------------------------------- targets: 16 costly layers

# Each kind at what makes it cost the most (kinds/<name>.py's cost terms: samples, terms,
# coefficients, particle count and life and radius), 16 layers of it: the costliest looks
# the schema allows, kind by kind, and one of every kind.
COSTLY = {
    "homogeneous": {},
    "height": {"falloff": 0.05},
    "cosine": {"terms": [{"amp": 0.1, "k": (1.0, 0.5 * i, 0.2), "phase": 0.3 * i} for i in range(8)]},
    "polynomial": {"coeffs": [0.5, 0.1, -0.1, 0.05, 0.02, -0.01, 0.005, 0.001]},
    "potential": {},
    "sphere": {"radius": 100.0},
    "particles": {"count": 64, "life_min": 500, "life_max": 1000, "radius": 100.0, "step": 0.05},
    "noise": {"mode": "volume", "samples": 128},
    "distance": {},
    "box": {"half_size": (100.0, 30.0, 100.0)},
    "ellipsoid": {"radii": (100.0, 30.0, 100.0)},
}


def costly_looks() -> dict[str, dict]:
    """16-layer looks, as params (the default preset's camera, sun and effects)."""
    from fogbank.kinds import KINDS
    base = P.preset_dict("default")
    looks = {f"16 x {k}": [{**KINDS[k].model().model_dump(mode="json"), **COSTLY[k]} for _ in range(16)]
             for k in KINDS}
    mixed = [{**KINDS[k].model().model_dump(mode="json"), **COSTLY[k]} for k in KINDS]
    mixed = [dict(l, density=0.002) if "density" in l else l for l in mixed]
    looks["16, every kind"] = (mixed * 2)[:16]
    out = {}
    for name, layers in looks.items():
        out[name] = FogParams.model_validate({**base, "layers": layers}).model_dump(mode="json")
    return out


def drag_latency(srv: ChildServer, size=(960, 540)) -> list[dict]:
    from fogbank.tools.bench_stream import drag_latency as measure
    ws = srv.url.replace("http", "ws", 1)
    rows = []
    for name, look in costly_looks().items():
        lat = asyncio.run(measure(ws, look, *size))
        rows.append({"look": name, **lat})
        print(f"  {name:18s} p50 {lat['p50_ms']:6.0f} p95 {lat['p95_ms']:6.0f} max {lat['max_ms']:6.0f} ms, "
              f"previews {lat['preview_width']:.0f} px wide, render {lat['render_ms']:.0f} ms")
    return rows


def sun_drag_latency(srv: ChildServer, size=(960, 540)) -> dict:
    """The default look with its sun's azimuth dragged: every change moves the sun, so
    every frame needs the sun's shadow map anew (render/passes/shadow.py)."""
    from fogbank.tools.bench_stream import drag_latency as measure, sun_change
    lat = asyncio.run(measure(srv.url.replace("http", "ws", 1), P.preset_dict("default"), *size,
                              change=sun_change))
    print(f"  the sun dragged, default look at {size[0]}x{size[1]}: p50 {lat['p50_ms']:.0f} p95 "
          f"{lat['p95_ms']:.0f} max {lat['max_ms']:.0f} ms, previews {lat['preview_width']:.0f} px wide")
    return lat


# ---------------------------------------------------------------- targets (issue 13)


def orbit_frames(r: Renderer, w: int, h: int, msaa: bool, n: int = 9) -> float:
    """Median ms of a frame of the default look with the camera orbiting (2 degrees of yaw
    a frame, so the scene pass is redrawn): render, read back, JPEG q80."""
    still = _still("default", w, h)

    def frame(i):
        s = still.model_copy(update={"time": 1.0 + i / 30, "camera": still.camera.model_copy(
            update={"yaw": still.camera.yaw + 2.0 * (i + 1)})})
        t0 = time.perf_counter()
        encode(r.render(s, slot="bench-orbit", msaa=msaa, lend=True, channels=4), "jpg", 80)
        return (time.perf_counter() - t0) * 1000
    frame(-1)
    return _median(frame, n)


def where_the_time_goes(r: Renderer, w: int = 1280, h: int = 720, n: int = 7, orbit: bool = True,
                        effects: dict | None = None) -> dict:
    """The orbiting frame without MSAA (or, `orbit` False, a stream's frame with the camera
    still and time running: MSAA, the scene pass and the fog that does not move held), pass
    by pass (the GL finished after each), plus read back and JPEG: median ms each. The fog
    plan (particles simulated, layers packed: CPU work on the renderer's preparation thread,
    render/frame.py) is waited for before the passes and timed with Renderer.begin: in a
    frame it runs while the GL thread draws the shadow, sky and scene passes."""
    from fogbank.render.passes import FRAME_PASSES
    still = _still("default", w, h)
    if effects:
        still = still.model_copy(update={"effects": still.effects.model_copy(update=effects)})
    times: dict[str, list[float]] = {}
    skip = 1 if orbit else 3   # a still camera's third frame draws the held fog, the fourth reuses it
    for i in range(n + skip):
        s = still.model_copy(update={"time": 1.0 + i / 30})
        if orbit:
            s = s.model_copy(update={"camera": still.camera.model_copy(update={"yaw": still.camera.yaw + 2.0 * (i + 1)})})
        t0 = time.perf_counter()
        f = r.begin(s, "bench-orbit" if orbit else "bench-still", not orbit, hold_fog=not orbit)
        f.channels = 4   # read back as a stream frame is, for its JPEG
        f.fog_plan()
        times.setdefault("begin, fog plan", []).append((time.perf_counter() - t0) * 1000)
        for p in FRAME_PASSES:
            r.ctx.finish()
            t0 = time.perf_counter()
            p.run(r, f)
            r.ctx.finish()
            if p.name != "output":
                times.setdefault(p.name, []).append((time.perf_counter() - t0) * 1000)
            else:
                times.setdefault("output (read back)", []).append((time.perf_counter() - t0) * 1000)
        t0 = time.perf_counter()
        encode(f.image, "jpg", 80)
        times.setdefault("JPEG q80", []).append((time.perf_counter() - t0) * 1000)
        r.keep_only(f)
    return {k: statistics.median(v[skip:]) for k, v in times.items()}


# The still camera's 720p frame of the default look as a stream draws it, by light: the
# look as it is (lit, "medium" grid), its grid lowered, and unlit (the papers' fog)
LIT_VARIANTS = (("lit, medium grid", {}), ("lit, low grid", {"light_quality": "low"}),
                ("unlit", {"lit": False, "shafts": 0.0}))
_LIT_PROBE = ("import json, sys; from fogbank.render.renderer import Renderer, create_context; "
              "from fogbank.tools.bench import where_the_time_goes as w; r = Renderer(create_context()); "
              "print(json.dumps(w(r, orbit=False, n=int(sys.argv[1]){extra})))")


def _probe(tree: str | None, n: int, effects: dict | None = None) -> float:
    """A still camera's 720p frame (ms, passes + JPEG, median of n) in a fresh process, of
    this code or of another checkout's `server` folder (`tree`, whose where_the_time_goes
    takes no effects)."""
    extra = f", effects=json.loads({json.dumps(json.dumps(effects))})" if effects else ""
    env = {**os.environ, **(_tree_env(tree) if tree else {})}
    out = subprocess.run([sys.executable, "-c", _LIT_PROBE.format(extra=extra), str(n)], env=env,
                         capture_output=True, text=True, timeout=900, check=True).stdout
    return sum(json.loads(out.strip().splitlines()[-1]).values())


def lit_cost(before_tree: str | None, rounds: int = 3, n: int = 7) -> dict:
    """Issue 32's speed figure: the still camera's 720p frame of the default look, whole
    (every pass, read back, JPEG), for each LIT_VARIANTS and, with `before_tree`, for the
    earlier code's default look; each a fresh process, all of them in turn in each round
    (the order turned every round), median of `rounds` rounds. Ratios to the earlier
    frame are taken within this run."""
    runs: dict[str, list[float]] = {}
    jobs = [(label, None, eff) for label, eff in LIT_VARIANTS]
    if before_tree:
        jobs.append(("before", before_tree, None))
    for i in range(rounds):
        for label, tree, eff in (jobs if i % 2 == 0 else jobs[::-1]):
            ms = _probe(tree, n, eff)
            runs.setdefault(label, []).append(ms)
            print(f"  round {i + 1} {label:18s} {ms:7.1f} ms")
    out = {label: {"ms": statistics.median(v), "rounds": v} for label, v in runs.items()}
    if before_tree:
        out["before"]["tree"] = before_tree
        for label, _ in LIT_VARIANTS:
            out[label]["vs_before"] = out[label]["ms"] / out["before"]["ms"]
    return out


def preview_orbit(w: int, h: int, frames: int = 40, step: float = 2.0) -> float:
    """Median ms of a drag's preview of the default look as a stream's worker draws it
    (draft, no MSAA, fog scale 4, time running; render alone, the JPEG not included) while
    the camera turns `step` degrees of heading a frame: the page's left-drag. This code
    warps the previews' scene pass (render/reproject.py); earlier code draws it whole.
    Runs in other checkouts too (preview_cost ships its source): it calls only what they
    have."""
    from fogbank.model.presets import merge
    r = Renderer(create_context())
    base = P.preset_dict("default")
    times = []
    for i in range(frames):
        cam = {**base["camera"], "yaw": base["camera"]["yaw"] + i * step}
        s = StillParams.model_validate(merge(base, {"camera": cam, "time": 1.0 + i / 24, "width": w, "height": h,
                                                    "effects": {"fog_scale": 4}}))
        t0 = time.perf_counter()
        r.render(s, slot="bench-drag", msaa=False, draft=True, lend=True, channels=4)
        times.append((time.perf_counter() - t0) * 1000)
    return statistics.median(times[5:])


PREVIEW_SIZES = ((640, 360), (448, 252))
# preview_orbit's own source, run in a fresh process of this code or of an earlier checkout
# (whose bench has no preview_orbit)
_PREVIEW_PROBE = "\n".join([
    "import json, statistics, sys, time",
    "from fogbank.model import presets as P",
    "from fogbank.model.params import StillParams",
    "from fogbank.render.renderer import Renderer, create_context",
    "{source}",
    "print(json.dumps(preview_orbit(int(sys.argv[1]), int(sys.argv[2]))))"])


def preview_cost(before_tree: str | None, rounds: int = 3) -> dict:
    """A drag's preview frame (preview_orbit) at PREVIEW_SIZES, each a fresh process, this
    code and with `before_tree` the earlier code's in turn (the order turned every round),
    median of `rounds` rounds."""
    runs: dict[str, list[float]] = {}
    jobs = [(f"{w}x{h}", w, h, which) for w, h in PREVIEW_SIZES for which in (("now", "before") if before_tree else ("now",))]
    for i in range(rounds):
        for label, w, h, which in (jobs if i % 2 == 0 else jobs[::-1]):
            env = {**os.environ, **(_tree_env(before_tree) if which == "before" else {})}
            probe = _PREVIEW_PROBE.format(source=inspect.getsource(preview_orbit))
            out = subprocess.run([sys.executable, "-c", probe, str(w), str(h)], env=env,
                                 capture_output=True, text=True, timeout=900, check=True).stdout
            ms = float(json.loads(out.strip().splitlines()[-1]))
            runs.setdefault(f"{label} {which}", []).append(ms)
            print(f"  round {i + 1} preview {label} {which:6s} {ms:7.1f} ms")
    out = {k: {"ms": statistics.median(v), "rounds": v} for k, v in runs.items()}
    if before_tree:
        for w, h in PREVIEW_SIZES:
            out[f"{w}x{h} now"]["vs_before"] = out[f"{w}x{h} now"]["ms"] / out[f"{w}x{h} before"]["ms"]
            out[f"{w}x{h} before"]["tree"] = before_tree
    return out


def preview_markdown(prev: dict) -> list[str]:
    """A drag's preview frame, against the earlier code."""
    L = ["## A drag's preview (issue 32)", "",
         "The default look's preview as a stream's worker draws it while the page's left-drag "
         "turns the camera 2 degrees a frame (draft, no MSAA, fog scale 4, time running; render "
         "alone), 40 frames, median of the last 35; each size and code a fresh process, in turn "
         "in each round, median of the rounds (ms). This code warps the previews while the camera "
         "only turns: the last preview's finished frame, else its scene pass (render/reproject.py).", "",
         "| size, code | ms | rounds | vs before |", "|---|---|---|---|"]
    return L + _rounds_rows(prev, lambda label, row: f"{label} ({row['tree']})" if "tree" in row else label) + [""]


def _rounds_rows(rows: dict, name_of) -> list[str]:
    """Table rows of (name, median ms, every round's ms, the ratio to before)."""
    out = []
    for label, row in rows.items():
        ratio = f"{row['vs_before']:.2f}x" if "vs_before" in row else "-"
        rounds = ", ".join(f"{v:.1f}" for v in row["rounds"])
        out.append(f"| {name_of(label, row)} | {row['ms']:.1f} | {rounds} | {ratio} |")
    return out


def workers_scaling(seconds: float, clients: int = 4) -> list[dict]:
    """Aggregate fps of `clients` streams at 640x360 against 1 and 2 render workers, and 4
    where this process may run on 8 cores or more (each worker is a process with its own
    context, and the web process and the clients need cores too)."""
    from fogbank.tools.bench_stream import delivered_fps
    rows = []
    from fogbank.render.gl import usable_cores
    for n in (1, 2, 4) if usable_cores() >= 8 else (1, 2):
        srv = ChildServer(env={"FOGBANK_WORKERS": str(n)})
        try:
            ws = srv.url.replace("http", "ws", 1)

            async def run_all():
                return await asyncio.gather(*[delivered_fps(ws, "v=1", 640, 360, seconds=seconds)
                                              for _ in range(clients)])
            fps = [x["fps"] for x in asyncio.run(run_all())]
        finally:
            srv.stop()
        rows.append({"workers": n, "clients": clients, "aggregate_fps": sum(fps)})
        print(f"  {n} worker(s), {clients} clients at 640x360: aggregate {sum(fps):.1f} fps")
    return rows


def _tree_env(tree: str) -> dict:
    """The environment of a server that runs another checkout's code: its `server` folder
    first on PYTHONPATH, ahead of what is there already (packages installed by path). Empty
    entries are dropped (Python would read one as the current folder)."""
    paths = [str(Path(tree).resolve())] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
    return {"PYTHONPATH": os.pathsep.join(paths)}


DELIVERED = (("drag_1280x720", 1280, 720, True, True), ("still_1280x720", 1280, 720, False, False),
             ("drag_640x360", 640, 360, True, True))


def delivered(seconds: float, rounds: int, before_tree: str | None = None) -> dict:
    """The delivered frame rates (DELIVERED: a client dragging as the page does, or watching a
    still camera), each the median of `rounds` rounds of a server started for the round.
    With `before_tree` (another checkout's `server` folder), each round also measures a
    server running that code, the two in turn (which first alternates): on this machine one
    version's figure moves by a third between runs minutes apart, so before and after are
    only compared within rounds. Returns {key: the round of median fps, with every round's
    fps in "rounds"}, and the same for the other code under "before_interleaved"."""
    from fogbank.tools.bench_stream import delivered_fps
    runs: dict[str, dict[str, list[dict]]] = {"now": {}, "before": {}}
    for i in range(rounds):
        order = ["now", "before"] if before_tree else ["now"]
        for which in order if i % 2 == 0 else order[::-1]:
            env = _tree_env(before_tree) if which == "before" else None
            srv = ChildServer(env=env)
            try:
                ws = srv.url.replace("http", "ws", 1)
                for key, w, h, orbit, drag in DELIVERED:
                    got = asyncio.run(delivered_fps(ws, "v=1", w, h, seconds=seconds, orbit=orbit, drag=drag))
                    runs[which].setdefault(key, []).append(got)
                    print(f"  round {i + 1} {which:6s} {key}: {got['fps']:.1f} fps delivered, frames "
                          f"{got.get('width', 0):.0f} px wide, render {got.get('render_ms', 0):.0f} ms")
            finally:
                srv.stop()

    def medians(by_key: dict[str, list[dict]]) -> dict:
        out = {}
        for key, got in by_key.items():
            mid = sorted(got, key=lambda g: g["fps"])[len(got) // 2]
            out[key] = {**mid, "fps": statistics.median(g["fps"] for g in got), "rounds": [g["fps"] for g in got]}
        return out
    res = medians(runs["now"])
    if before_tree:
        res["before_interleaved"] = {"tree": before_tree, **medians(runs["before"])}
    return res


def targets(r: Renderer, seconds: float, analytic: list[dict], rounds: int = 3,
            before_tree: str | None = None) -> dict:
    """Every figure issue 13 sets a target for, measured in this run."""
    from fogbank.tools import bench_vtk
    out: dict = {}
    print("  orbiting frames in this process (render, read back, JPEG q80)")
    for w, h in ((1280, 720), (640, 360)):
        for msaa in (False, True):
            ms = orbit_frames(r, w, h, msaa)
            out[f"orbit_{w}x{h}_{'msaa' if msaa else 'nomsaa'}_ms"] = ms
            print(f"    {w}x{h} {'MSAA' if msaa else 'no MSAA'}: {ms:.1f} ms")
    out["where_720p"] = where_the_time_goes(r)
    print("    720p no MSAA by pass: " + ", ".join(f"{k} {v:.1f}" for k, v in out["where_720p"].items()))
    out["where_720p_still"] = where_the_time_goes(r, orbit=False)
    print("    720p still camera by pass: " + ", ".join(f"{k} {v:.1f}" for k, v in out["where_720p_still"].items()))
    print("  the still camera's 720p frame by light (issue 32), each in a fresh process, in turn")
    out["lit_cost"] = lit_cost(before_tree, rounds=rounds)
    print("  a drag's preview frames (issue 32), each in a fresh process, in turn")
    out["preview_cost"] = preview_cost(before_tree, rounds=rounds)
    version = bench_vtk.available()
    if version:
        vt = [bench_vtk.orbit(w, h) for w, h in ((1280, 720), (640, 360))]
        fb = orbit_frames(r, 1280, 720, False)   # again, right after VTK's: the ratio's pair
        out["vtk"] = {"version": version, "triangles": vt[0]["triangles"], "gl": vt[0]["gl"],
                      "ms_1280x720": vt[0]["ms"], "ms_640x360": vt[1]["ms"], "fogbank_ms_1280x720": fb,
                      "ratio_1280x720": vt[0]["ms"] / fb}
        print(f"    VTK {version} ({vt[0]['triangles']} triangles): 1280x720 {vt[0]['ms']:.1f} ms, "
              f"640x360 {vt[1]['ms']:.1f} ms; fogbank 720p {fb:.1f} ms: VTK / fogbank {vt[0]['ms'] / fb:.2f}")
    else:
        out["vtk"] = None
        print("    VTK is not installed (pip install -e '.[bench]'): no comparison")
    out.update(delivered(seconds, rounds, before_tree))
    srv = ChildServer()
    try:
        print("  16 costly layers at 960x540, a slider dragged: control-to-frame latency")
        out["costly"] = drag_latency(srv)
        out["sun_drag"] = sun_drag_latency(srv)
    finally:
        srv.stop()
    if before_tree:   # the sun dragged over a server of the earlier code too, right after
        srv = ChildServer(env=_tree_env(before_tree))
        try:
            print(f"  the same with a server of {before_tree}:")
            out.setdefault("before_interleaved", {"tree": before_tree})["sun_drag"] = sun_drag_latency(srv)
        finally:
            srv.stop()
    out["workers"] = workers_scaling(seconds)
    out["analytic"] = {row["kind"]: row["speedup"] for row in analytic}
    return out


TARGETS = [   # (label, target, how the figure is read from targets(), unit, met if)
    ("1280x720 orbiting, delivered to a dragging client", 24.0, lambda t: t["drag_1280x720"]["fps"], "fps", ">="),
    ("1280x720, still camera, delivered", 40.0, lambda t: t["still_1280x720"]["fps"], "fps", ">="),
    ("640x360 orbiting, delivered to a dragging client", 50.0, lambda t: t["drag_640x360"]["fps"], "fps", ">="),
    ("VTK's unfogged 720p frame / fogbank's foggy one (no MSAA)", 3.0,
     lambda t: t["vtk"]["ratio_1280x720"] if t.get("vtk") else None, "x", ">="),
    ("16 layers, 960x540: control-to-frame p95, worst look", 250.0,
     lambda t: max(row["p95_ms"] for row in t["costly"]), "ms", "<="),
    ("the sun dragged, default look, 960x540: control-to-frame p95", 250.0,
     lambda t: t["sun_drag"]["p95_ms"], "ms", "<="),
    ("analytic / raymarch of equal accuracy, cosine", 10.0, lambda t: t["analytic"].get("cosine"), "x", ">="),
    ("analytic / raymarch of equal accuracy, potential", 10.0, lambda t: t["analytic"].get("potential"), "x", ">="),
    ("2 render workers / 1, aggregate fps", None,
     lambda t: t["workers"][1]["aggregate_fps"] / t["workers"][0]["aggregate_fps"], "x", None),
]


def _timed(f) -> float:
    t0 = time.perf_counter()
    f()
    return (time.perf_counter() - t0) * 1000


# ---------------------------------------------------------------- 4-6: the service


def streaming(r: Renderer, srv: ChildServer, seconds: float) -> list[dict]:
    from fogbank.tools.bench_stream import control_latency, delivered_fps
    from fogbank.stream.session import PREVIEW_QUALITY
    rows = []
    ws = srv.url.replace("http", "ws", 1)
    for w, h in ((640, 360), (1280, 720), (1920, 1080)):
        for orbit in (False, True):
            got = asyncio.run(delivered_fps(ws, "v=1", w, h, seconds=seconds, orbit=orbit))
            # the same frames without the network: render + encode in this process
            still = _still("default", w, h)
            if orbit:
                still = still.model_copy(update={"effects": still.effects.model_copy(
                    update={"fog_scale": 2 if w * h <= 640 * 360 else 4})})
            q = PREVIEW_QUALITY if orbit else 80

            def frame(i):
                s = still.model_copy(update={"time": 1.0 + i * 0.033})
                if orbit:
                    s = s.model_copy(update={"camera": s.camera.model_copy(update={"yaw": 2.0 * i})})
                t0 = time.perf_counter()
                img = r.render(s, slot="bench-stream", msaa=not orbit, lend=True, channels=4)
                encode(img, "jpg", q)
                return time.perf_counter() - t0
            frame(0)
            local = 1.0 / _median(frame, 7)
            row = {"size": f"{w}x{h}", "camera": "orbit" if orbit else "still", "delivered_fps": got["fps"],
                   "render_encode_fps": local, "ratio": got["fps"] / local,
                   "server_render_ms": got.get("render_ms"), "server_encode_ms": got.get("encode_ms"),
                   "frame_kb": got.get("kb")}
            rows.append(row)
            print(f"  {w}x{h} {row['camera']:5s} delivered {got['fps']:5.1f} fps, render+encode "
                  f"{local:5.1f} fps, ratio {row['ratio']:.2f}")
        lat = asyncio.run(control_latency(ws, "v=1", w, h, changes=20))
        rows.append({"size": f"{w}x{h}", "latency": lat})
        print(f"  {w}x{h} control-to-frame p50 {lat['p50_ms']:.0f} p95 {lat['p95_ms']:.0f} "
              f"p99 {lat['p99_ms']:.0f} ms")
    return rows


CONCURRENCY = ((1, 640, 360), (2, 640, 360), (4, 640, 360), (8, 640, 360), (2, 1280, 720), (4, 1280, 720))


def concurrency(srv: ChildServer, seconds: float) -> list[dict]:
    """Clients streaming the default look at once from one server (one render worker):
    each client's fps, their sum, the slowest over the fastest, and the process tree's
    memory. Sessions drawn in turn must each get a share, and must not push each other's
    scene passes out of the worker's cache at every frame."""
    from fogbank.tools.bench_stream import delivered_fps
    ws = srv.url.replace("http", "ws", 1)
    rows = []
    for n, w, h in CONCURRENCY:
        async def run_all():
            return await asyncio.gather(*[delivered_fps(ws, "v=1", w, h, seconds=seconds)
                                          for _ in range(n)])
        res = asyncio.run(run_all())
        fps = [x["fps"] for x in res]
        row = {"clients": n, "size": f"{w}x{h}", "per_client_fps": fps, "aggregate_fps": sum(fps),
               "fairness": min(fps) / max(fps) if max(fps) > 0 else 0.0, "server_rss_mb": srv.rss_mb()}
        rows.append(row)
        print(f"  {n} clients at {w}x{h}: aggregate {row['aggregate_fps']:.1f} fps, per client "
              f"{min(fps):.1f}..{max(fps):.1f}, fairness {row['fairness']:.2f}, RSS {row['server_rss_mb']:.0f} MB")
    return rows


def stills(srv: ChildServer, repeat: int = 3) -> dict:
    out = {}
    for fmt in ("png", "jpg", "webp"):
        def once(i):
            url = f"{srv.url}/api/still.{fmt}?width=1920&height=1080&time={10 + i + len(out) * 10}"
            t0 = time.perf_counter()
            with urllib.request.urlopen(url, timeout=120) as resp:
                resp.read()
            return (time.perf_counter() - t0) * 1000
        once(-5)
        out[fmt] = _median(once, repeat)
        print(f"  1920x1080 {fmt:4s} {out[fmt]:7.1f} ms")
    return out


def process_boundary(n: int = 300) -> dict:
    """What handing a job to a render worker process and its result back costs: an empty
    job's round trip, and a 640x360 frame's total time minus its time in the worker."""
    import asyncio

    from fogbank.workers import worker
    from fogbank.settings import Settings
    from fogbank.workers.supervisor import Supervisor

    async def measure():
        sup = Supervisor(Settings(batch_workers=0))
        await sup.start()
        try:
            slot = sup.interactive.slots[0]
            for _ in range(20):
                await sup.call(slot, worker.noop, deadline=30)
            rt = []
            for _ in range(n):
                t0 = time.perf_counter()
                await sup.call(slot, worker.noop, deadline=30)
                rt.append((time.perf_counter() - t0) * 1000)
            still = _still("default", 640, 360)
            hand = []
            for i in range(60):
                st = still.model_copy(update={"time": 0.03 * i})
                t0 = time.perf_counter()
                out = await sup.call(slot, worker.frame, st, "bench", True, 80, deadline=30)
                hand.append((time.perf_counter() - t0) * 1000 - out["run_s"] * 1000)
            return rt, hand[10:]
        finally:
            await sup.stop()
    rt, hand = asyncio.run(measure())
    rt.sort()
    hand.sort()
    out = {"noop_p50_ms": rt[len(rt) // 2], "noop_p90_ms": rt[int(len(rt) * 0.9)],
           "frame_handover_p50_ms": hand[len(hand) // 2], "frame_handover_p90_ms": hand[int(len(hand) * 0.9)]}
    print(f"  empty job round trip p50 {out['noop_p50_ms']:.2f} ms; 640x360 frame hand-over "
          f"p50 {out['frame_handover_p50_ms']:.2f} ms")
    return out


# ---------------------------------------------------------------- report


def run(out_dir: str = "docs", quick: bool = False, only_targets: bool = False,
        before: str | None = None, before_tree: str | None = None, only_lit: bool = False) -> dict:
    if only_lit:   # issue 32's figure alone: the lit frame's cost, before and after in one run
        res = {"command": " ".join(["fogbank"] + sys.argv[1:]), "cpu": _cpu(),
               "date": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
               "lit_cost": lit_cost(before_tree, rounds=1 if quick else 5),
               "preview_cost": preview_cost(before_tree, rounds=1 if quick else 3)}
        print(json.dumps(res["lit_cost"]))
        Path(out_dir).mkdir(parents=True, exist_ok=True)
        Path(out_dir, "bench-lit.json").write_text(json.dumps(res, indent=1))
        Path(out_dir, "bench-lit.md").write_text("\n".join(
            ["# fogbank benchmark: lit fog's cost", "", f"`{res['command']}` on {res['cpu']}, {res['date']}.", ""]
            + lit_markdown(res["lit_cost"]) + preview_markdown(res["preview_cost"])))
        print(f"wrote {out_dir}/bench-lit.json and bench-lit.md")
        return res
    earlier = json.loads(Path(before).read_text()) if before else None   # read first: fail fast
    r = Renderer(create_context())
    info = r.info()
    seconds = 3.0 if quick else 6.0
    res: dict = {"command": " ".join(["fogbank"] + sys.argv[1:]), "cpu": _cpu(), "gl": info,
                 "date": time.strftime("%Y-%m-%d %H:%M:%S %Z")}
    print(f"fogbank bench on {res['cpu']}, {info['renderer']}")
    print("1. analytic fog against raymarching (fog pass, 1280x720, max|dT| <= 1/255)")
    res["analytic_vs_raymarch"] = analytic_vs_raymarch(r, max_steps=512 if quick else 2048)
    print("0. the targets of issue 13")
    res["targets"] = targets(r, seconds, res["analytic_vs_raymarch"], rounds=1 if quick else 3,
                             before_tree=before_tree)
    if earlier:
        res["before"] = earlier
    if only_targets:
        Path(out_dir).mkdir(parents=True, exist_ok=True)
        Path(out_dir, "bench.json").write_text(json.dumps(res, indent=1))
        print(f"wrote {out_dir}/bench.json")
        return res
    print("2. Biri Table 1 (800x600)")
    res["biri_table1"] = biri_table1(r)
    print("3. Gawron Tables 2 and 3 (1920x1080)")
    res["gawron"] = gawron(r)
    srv = ChildServer()
    try:
        print("4. streaming (default preset)")
        res["streaming"] = streaming(r, srv, seconds)
        print("5. concurrency")
        res["concurrency"] = concurrency(srv, seconds)
        print("6. stills over HTTP")
        res["stills_ms"] = stills(srv)
    finally:
        srv.stop()
    if before_tree:
        srv = ChildServer(env=_tree_env(before_tree))
        try:
            print(f"5. concurrency, the earlier code ({before_tree})")
            res["concurrency_before"] = concurrency(srv, seconds)
        finally:
            srv.stop()
    print("7. the process boundary (web process <-> render worker)")
    res["process_boundary"] = process_boundary()
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    Path(out_dir, "bench.json").write_text(json.dumps(res, indent=1))
    Path(out_dir, "bench.md").write_text(markdown(res))
    print(f"wrote {out_dir}/bench.md and {out_dir}/bench.json")
    return res


def _figure(fn, t: dict | None):
    if not t:
        return None
    try:
        return fn(t)
    except (KeyError, TypeError, IndexError, ZeroDivisionError):
        return None


def _before_sentence(res: dict, bi: dict | None) -> str:
    """What the 'before' column holds in this run: another version's bench.json (--before),
    a server of another checkout run in turn with this one's (--before-tree), or nothing."""
    said = []
    if res.get("before"):
        said.append(f"'before' is the benchmark of {res['before'].get('version', 'an earlier version')} "
                    "read from its bench.json (--before), measured in another run")
    if bi:
        said.append(f"the delivered frame rates' 'before' is a server of the code in `{bi['tree']}`, "
                    "run in turn with this one's in the same rounds"
                    + (", and the sun drag's a server of that code run right after this one's"
                       if "sun_drag" in bi else ""))
    if not said:
        return "Each figure as the issue defines it, measured in this run; no earlier version was measured."
    return "Each figure as the issue defines it, measured in this run; " + "; ".join(said) + "."


def targets_markdown(res: dict) -> list[str]:
    t = res["targets"]
    b = (res.get("before") or {}).get("targets")
    fmt = lambda v, unit: "-" if v is None else (f"{v:.2f}{unit}" if unit == "x" else f"{v:.1f} {unit}")  # noqa: E731
    bi = t.get("before_interleaved")
    if bi:   # the delivered figures' before: measured in turn with this code's, in the same rounds
        b = {**(b or {}), **{k: v for k, v in bi.items() if k != "tree"}}
    L = ["## 0. Issue 13's targets", "", _before_sentence(res, bi), "",
         "| target | before | now | wanted | met |", "|---|---|---|---|---|"]
    for label, want, fn, unit, how in TARGETS:
        now, was = _figure(fn, t), _figure(fn, b)
        if how is None or now is None:
            met = "-"
        else:
            met = "yes" if (now >= want if how == ">=" else now <= want) else "no"
        wanted = "-" if want is None else f"{how} {want:g}{'x' if unit == 'x' else ' ' + unit}"
        L.append(f"| {label} | {fmt(was, unit)} | {fmt(now, unit)} | {wanted} | {met} |")
    from fogbank.stream.session import PREVIEW_FPS, PREVIEW_FPS_SMALL, preview_budget_ms
    L += ["", f"Delivered frames while dragging are previews: the adaptive ladder sizes them to a "
          f"budget by the view's size ({preview_budget_ms(1280, 720):.1f} ms at 1280x720, {PREVIEW_FPS:g} fps, "
          f"and {preview_budget_ms(640, 360):.1f} ms at 640x360, {PREVIEW_FPS_SMALL:g} fps, less the JPEG, pipe "
          "and socket; stream/session.py), so their width is part of the figure. Each delivered figure is the median "
          "of rounds, a server started for each (the round of median fps gives width and render time):", "",
          "| stream | fps | each round | frames px wide | server render ms |", "|---|---|---|---|---|"]
    for key, *_ in DELIVERED:
        g = t[key]
        rounds = ", ".join(f"{x:.1f}" for x in g.get("rounds", [g["fps"]]))
        L.append(f"| {key} | {g['fps']:.1f} | {rounds} | {g.get('width', 0):.0f} | {g.get('render_ms', 0):.0f} |")
    if bi:
        L += ["", f"The same rounds with a server of the earlier code (`{bi['tree']}`), the two servers in turn "
              "within each round (which first alternates), so that the machine's drift falls on both:", "",
              "| stream | before fps | its rounds | now fps | its rounds | now / before |", "|---|---|---|---|---|---|"]
        for key, *_ in DELIVERED:
            g, o = t[key], bi[key]
            each = [", ".join(f"{x:.1f}" for x in d.get("rounds", [d["fps"]])) for d in (o, g)]
            L.append(f"| {key} | {o['fps']:.1f} | {each[0]} | {g['fps']:.1f} | {each[1]} | {g['fps'] / o['fps']:.2f} |")
    L += ["", "Orbiting frames made in this process (render, read back, JPEG q80), default look:", "",
          "| size | no MSAA ms | MSAA ms |", "|---|---|---|"]
    for w, h in ((1280, 720), (640, 360)):
        L.append(f"| {w}x{h} | {t[f'orbit_{w}x{h}_nomsaa_ms']:.1f} | {t[f'orbit_{w}x{h}_msaa_ms']:.1f} |")
    v = t.get("vtk")
    if v:
        L += ["", f"VTK {v['version']} ({v['gl']}, {v['triangles']} triangles: fogbank's own scene mesh, unfogged, "
              f"lit per vertex), orbiting, render + read back + JPEG q80: 1280x720 {v['ms_1280x720']:.1f} ms, "
              f"640x360 {v['ms_640x360']:.1f} ms. fogbank's foggy 720p frame right after it: "
              f"{v['fogbank_ms_1280x720']:.1f} ms."]
    L += ["", "Where fogbank's orbiting 720p frame goes (no MSAA, the GL finished after each pass):", "",
          "| part | ms |", "|---|---|"]
    L += [f"| {k} | {ms:.1f} |" for k, ms in t["where_720p"].items()]
    if t.get("where_720p_still"):
        L += ["", "Where a 720p frame goes with the camera still and time running (a stream's full frame: "
              "MSAA, the scene pass held, and the fog's time-invariant layers and shafts held with it, "
              "render/passes/fog.py):", "", "| part | ms |", "|---|---|"]
        L += [f"| {k} | {ms:.1f} |" for k, ms in t["where_720p_still"].items()]
    L += ["", "16 costly layers at 960x540 (tools/bench.py COSTLY): a slider dragged (interact on, a "
          "density change every 150 ms, time running), each change to the first frame that shows it:", "",
          "| look | p50 ms | p95 ms | max ms | previews px wide | render ms |" + (" before p95 ms |" if b else ""),
          "|---|---|---|---|---|---|" + ("---|" if b else "")]
    before_rows = {row["look"]: row for row in (b or {}).get("costly", [])}
    for row in t["costly"]:
        extra = ""
        if b:
            br = before_rows.get(row["look"])
            extra = f" {br['p95_ms']:.0f} |" if br else " - |"
        L.append(f"| {row['look']} | {row['p50_ms']:.0f} | {row['p95_ms']:.0f} | {row['max_ms']:.0f} | "
                 f"{row['preview_width']:.0f} | {row['render_ms']:.0f} |" + extra)
    L += ["", "Render workers (4 clients at 640x360, aggregate fps):", "",
          "| workers | fps | / 1 worker |", "|---|---|---|"]
    one = next(row["aggregate_fps"] for row in t["workers"] if row["workers"] == 1)
    L += [f"| {row['workers']} | {row['aggregate_fps']:.1f} | {row['aggregate_fps'] / one:.2f}x |"
          for row in t["workers"]]
    return L + [""]


def lit_markdown(lit: dict) -> list[str]:
    """Issue 32's figure: the still camera's 720p frame by light, and against the earlier code."""
    before = lit.get("before")
    L = ["## Lit fog's cost (issue 32)", "",
         "The default look's 720p frame with the camera still and time running, as a stream draws "
         "it (MSAA, the scene pass and the fog that does not move held; every pass, read back and "
         "JPEG q80, the GL finished after each), each light in a fresh process, all in turn in each "
         "round, median of the rounds (ms). The limit: at most 30% over the earlier code's frame, "
         "or a quality setting a look can lower (`effects.light_quality`).", "",
         "| light | ms | rounds | vs before |", "|---|---|---|---|"]
    L += _rounds_rows(lit, lambda label, row: f"before ({row['tree']})" if label == "before" and "tree" in row
                      else label)
    if before is None:
        L += ["", "(no earlier tree was given: `--before-tree DIR`)"]
    return L + [""]


def markdown(res: dict) -> str:
    L = ["# fogbank benchmark", "",
         f"`{res['command']}` on {res['cpu']}, GL: {res['gl']['renderer']} ({res['gl']['version']}), "
         f"{res['date']}. Medians of repeats; ratios are of two things timed in the same run.", ""]
    if "targets" in res:
        L += targets_markdown(res)
    if "lit_cost" in res.get("targets", {}):
        L += lit_markdown(res["targets"]["lit_cost"])
    if "preview_cost" in res.get("targets", {}):
        L += preview_markdown(res["targets"]["preview_cost"])
    L += [
         "## 1. Analytic fog against raymarching", "",
         "Fog pass alone at 1280x720, one layer of each exponential kind (from the presets), "
         "default camera, the fog toward the sun and the shafts off (the raymarch integrates "
         "the view ray only; before, the analytic pass also integrated toward the sun and both "
         "sampled the shafts). The raymarch is the same pass with the midpoint rule over the "
         "density; its steps are the fewest that keep max |T - T_ref| <= 1/255 over the frame "
         "against the float64 closed form. A raymarch of n steps evaluates each cosine term n "
         "times, the closed form once with a sine and a cosine: where 7 steps are enough (Biri "
         "figure 6's bands, waves 43 to 270 m long), the closed form cannot be 10x faster.", "",
         "| kind | analytic ms | analytic max dT | raymarch steps | raymarch ms | raymarch / analytic |",
         "|---|---|---|---|---|---|"]
    for row in res["analytic_vs_raymarch"]:
        steps = row["raymarch_steps"] if row["raymarch_steps"] else "> 2048"
        L.append(f"| {row['kind']} | {row['analytic_ms']:.1f} | {row['analytic_max_err']:.1e} | {steps} | "
                 f"{row['raymarch_ms']:.1f} | {row['speedup']:.1f}x |")
    L += ["", "## 2. Biri et al. 2002, Table 1", "",
          "800x600 frames, whole frame (scene pass redrawn, fog, composite, readback). Our fog "
          "targets are 1/1, 1/2 and 1/4 of the frame; the paper's textures are listed by texel count.", "",
          "| fog | fog texels (ours) | fps (ours) | paper texture | paper fps |", "|---|---|---|---|---|"]
    paper_match = {"800x600": "512x512", "400x300": "256x256", "200x150": "128x128"}
    for row in res["biri_table1"]:
        pm = paper_match[row["fog_texture"]]
        L.append(f"| {row['fog']} | {row['fog_texture']} | {row['fps']:.1f} | {pm} | "
                 f"{BIRI_TABLE1[row['fog']][pm]} |")
    g = res["gawron"]
    L += ["", "## 3. Gawron & Boryczka 2018, Tables 2 and 3", "",
          "1920x1080, the gawron-distance preset, scene pass cached, readback subtracted.", "",
          "| | ours (ms) | paper (ms, GTX 970) |", "|---|---|---|",
          f"| fog alone | {g['fog_ms']:.1f} | 0.20 |",
          f"| fog + blur, single pass | {g['single_ms']:.1f} | 0.44 |",
          f"| fog + blur, separate passes | {g['separate_ms']:.1f} | 0.65 |",
          f"| single / separate | {g['single_over_separate']:.2f} | 0.68 |"]
    L += ["", "## 4. Streaming", "",
          "Default preset, a real WebSocket client on 127.0.0.1 acknowledging every frame. "
          "'render+encode' is the same frames made in this process without the network.", "",
          "| size | camera | delivered fps | render+encode fps | ratio | server render ms | encode ms | KB |",
          "|---|---|---|---|---|---|---|---|"]
    for row in res["streaming"]:
        if "latency" in row:
            continue
        L.append(f"| {row['size']} | {row['camera']} | {row['delivered_fps']:.1f} | {row['render_encode_fps']:.1f} | "
                 f"{row['ratio']:.2f} | {row['server_render_ms'] or 0:.1f} | {row['server_encode_ms'] or 0:.1f} | "
                 f"{row['frame_kb'] or 0:.0f} |")
    L += ["", "Control change to the first frame that shows it:", "", "| size | p50 ms | p95 ms | p99 ms |",
          "|---|---|---|---|"]
    for row in res["streaming"]:
        if "latency" in row:
            lat = row["latency"]
            L.append(f"| {row['size']} | {lat['p50_ms']:.0f} | {lat['p95_ms']:.0f} | {lat['p99_ms']:.0f} |")
    before = {(row["clients"], row.get("size", "640x360")): row for row in res.get("concurrency_before", [])}
    L += ["", "## 5. Concurrency", "",
          "Clients streaming the default look at once from one server (one render worker), camera still, "
          "time running" + (", and the same from a server of the earlier code run right after" if before else "")
          + ":", "",
          "| clients | size | aggregate fps | per client fps | slowest / fastest | server RSS MB |"
          + (" before: aggregate fps | per client fps |" if before else ""),
          "|---|---|---|---|---|---|" + ("---|---|" if before else "")]
    for row in res["concurrency"]:
        fps = row["per_client_fps"]
        size = row.get("size", "640x360")
        line = (f"| {row['clients']} | {size} | {row['aggregate_fps']:.1f} | {min(fps):.1f} - {max(fps):.1f} | "
                f"{row['fairness']:.2f} | {row['server_rss_mb']:.0f} |")
        b = before.get((row["clients"], size))
        if before:
            line += (f" {b['aggregate_fps']:.1f} | {min(b['per_client_fps']):.1f} - {max(b['per_client_fps']):.1f} |"
                     if b else " - | - |")
        L.append(line)
    s = res["stills_ms"]
    L += ["", "## 6. Stills (1920x1080, over HTTP, uncached)", "", "| format | ms |", "|---|---|"]
    L += [f"| {k} | {v:.0f} |" for k, v in s.items()]
    pb = res.get("process_boundary")
    if pb:
        L += ["", "## 7. The process boundary", "",
              "GL runs in render worker processes; each job and its result cross a pipe "
              "(pebble). Measured through the supervisor in this process.", "",
              "| | p50 ms | p90 ms |", "|---|---|---|",
              f"| empty job, round trip | {pb['noop_p50_ms']:.2f} | {pb['noop_p90_ms']:.2f} |",
              f"| 640x360 frame, total minus time in the worker | {pb['frame_handover_p50_ms']:.2f} | "
              f"{pb['frame_handover_p90_ms']:.2f} |"]
    return "\n".join(L) + "\n"
