"""What runs inside a render worker process: the GL context and the jobs it serves.

A worker is a process started by the supervisor (supervisor.py) through a pebble
ProcessPool of one worker. `init` builds its own EGL context and Renderer; each job
renders and encodes, and only encoded bytes (or a small array) go back to the web
process. A job past its deadline is stopped by the supervisor killing this process, the
only sure way to stop a GL call, so SIGTERM is left at its default action (die now)
rather than a Python handler that would wait for the GL call to return.

Every job's result carries the worker's pid and resident memory. After a job the worker
holds itself to its memory budget: over it, it frees its GL caches and returns heap to
the system; still over, it asks to be recycled (the supervisor replaces it between jobs).
"""

from __future__ import annotations

import ctypes
import gc
import os
import signal
import time
from typing import Any

import numpy as np

from fogbank.workers import proctree

_renderer = None
_config: dict[str, Any] = {}


def rss_bytes() -> int:
    """This process's resident set size."""
    return proctree.rss_bytes(os.getpid())


M_TRIM_THRESHOLD = -1
M_MMAP_THRESHOLD = -3
M_ARENA_MAX = -8
# free memory a heap keeps at its top before it gives it back (see _fix_mmap_threshold)
TRIM_THRESHOLD_BYTES = 16 << 20
PR_SET_PDEATHSIG = 1


def _libc():
    try:
        return ctypes.CDLL("libc.so.6")
    except OSError:
        return None


def _trim_heap() -> None:
    """Give freed heap back to the system (glibc keeps it otherwise)."""
    libc = _libc()
    if libc is not None:
        libc.malloc_trim(0)


def _fix_mmap_threshold() -> None:
    """Render targets live in malloc'd memory (llvmpipe). glibc raises its mmap threshold
    each time a large block is freed, after which large blocks come from the heap, where
    freed targets fragment and are never returned: RSS grew to twice the cache. A fixed
    threshold keeps every block over 128 KiB in its own mapping, returned on release."""
    libc = _libc()
    if libc is not None:
        libc.mallopt(M_MMAP_THRESHOLD, 128 * 1024)
        # The renderer prepares each frame's fog plan on a thread of its own
        # (render/frame.py); glibc would give that thread its own heap arena, which held
        # ~60 MB more of the process tree in the churn soak (923 MB at the end, against
        # 857 MB before the thread) and doubled the peak growth. Two arenas serve the GL
        # thread, the preparation thread and llvmpipe's threads as before.
        libc.mallopt(M_ARENA_MAX, 2)
        # A fixed mmap threshold also fixes the trim threshold, at glibc's 128 KiB: each
        # frame's transient blocks under the mmap threshold (llvmpipe's vertex and bin
        # buffers, numpy's) were given back at the heap's top as they were freed and
        # faulted in again by the next frame, about 12 MB of brk a frame orbiting at
        # 1280x720: 1260-1500 page faults a frame, 97-109 -> 87-90 ms a frame with them
        # gone, and 24-25 -> 19-22 ms at 448x252 (the drag's previews). The heap keeps up
        # to 16 MB free instead (8 MB was enough at 1280x720, 16 at 1920x1080); the memory
        # budget's malloc_trim (_run) still returns all of it. The threshold holds for each
        # arena's heap: at most 2 x 16 MB kept free in all.
        libc.mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES)


def _build():
    from fogbank.render.renderer import Renderer, create_context
    return Renderer(create_context(_config["backend"], _config["device"], _config.get("threads", 0)),
                    cache_bytes=_config["cache_bytes"])


def init(backend: str, device: int | None, nice: int, cache_bytes: int, memory_bytes: int,
         threads: int = 0, workers: int = 1) -> None:
    """pebble initializer: one EGL context and Renderer for this process's life, with
    `threads` raster threads if on llvmpipe (0: render/gl.py raster_threads for a share of
    the cores among `workers` interactive workers)."""
    global _renderer
    signal.signal(signal.SIGTERM, signal.SIG_DFL)   # a kill lands even inside a GL call
    libc = _libc()
    if libc is not None:
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL)  # never outlive the web process
    if nice:
        os.nice(nice)   # batch work yields the cores to interactive frames
    _fix_mmap_threshold()
    from fogbank.render.gl import raster_threads
    _config.update(backend=backend, device=device, cache_bytes=cache_bytes, memory_bytes=memory_bytes,
                   threads=threads or raster_threads(workers))
    _renderer = _build()
    _warm_up()


def _warm_up() -> None:
    """Draw the default look once, small, with and without MSAA, and as a stream's frames
    while time runs over a still camera: builds the scene's meshes and compiles the
    programs a first frame needs (and the held fog's, render/passes/fog.py), so that the
    first client of a new (or replaced) worker does not wait for them."""
    from fogbank.model import presets
    from fogbank.model.params import StillParams
    still = StillParams.model_validate({**presets.preset_dict("default"), "width": 64, "height": 36})
    _renderer.render(still, slot="warm-up")
    _renderer.render(still, slot="warm-up", msaa=False)
    # held frames at the default's fog scale with MSAA, and at 1/4 without (a refinement
    # below the look's quality has a coarser fog): the held fog's and held composite's
    # programs (about 0.4 s more here; other looks compile theirs on their first frames)
    for scale in (2, 4):
        look = still.model_copy(update={"effects": still.effects.model_copy(update={"fog_scale": scale})})
        for t in (0.1, 0.2, 0.3):
            _renderer.render(look.model_copy(update={"time": still.time + t}), slot="warm-up", hold_fog=True,
                             msaa=scale == 2)
    _renderer.drop_slot("warm-up")


def _gl_failed(exc: BaseException) -> bool:
    name = type(exc).__module__ + "." + type(exc).__name__
    return "moderngl" in name or "GL error" in str(exc)


def _run(fn) -> dict[str, Any]:
    """Run `fn(renderer)`; a GL failure rebuilds the renderer (the job still fails) so
    the next job finds a working context. Adds pid, memory and recycle advice."""
    global _renderer
    t0 = time.perf_counter()
    try:
        out = fn(_renderer)
        err = _renderer.ctx.error
        if err != "GL_NO_ERROR":
            raise RuntimeError(f"GL error after a job: {err}")
    except BaseException as exc:
        if _gl_failed(exc) or not _healthy():
            try:
                _renderer.ctx.release()
            except Exception:  # noqa: BLE001 - the context is already gone
                pass
            _renderer = _build()
        raise
    out["run_s"] = time.perf_counter() - t0
    out["pid"] = os.getpid()
    out["rss"] = rss_bytes()
    out["recycle"] = False
    budget = _config.get("memory_bytes", 0)
    if budget and out["rss"] > budget:
        _renderer.release_caches()
        if _VIDEO is not None:   # the sessions' encoders too (their next frames are keyframes)
            _VIDEO.clear()
        gc.collect()
        _trim_heap()
        out["rss"] = rss_bytes()
        out["recycle"] = out["rss"] > budget
    return out


def _healthy() -> bool:
    try:
        return isinstance(_renderer.ctx.error, str)
    except Exception:  # noqa: BLE001
        return False


# ---------------------------------------------------------------- jobs


def probe() -> dict[str, Any]:
    """A tiny draw and readback: proves this worker's GL pipeline answers."""
    def fn(r):
        t0 = time.perf_counter()
        ok = r.probe()
        if not ok:   # the pipeline answers but draws wrong: not alive
            raise RuntimeError("GL error after a job: the probe read back the wrong colour")
        return {"ok": ok, "ms": (time.perf_counter() - t0) * 1000.0, "info": r.info(),
                "blas_threads": os.environ.get("OPENBLAS_NUM_THREADS")}
    return _run(fn)


def frame(still, slot: str, msaa: bool, quality: int, show: str = "shaded", layer: int = 0,
          hold_fog: bool = False, draft: bool = False, codec: str = "jpeg", bitrate: int = 0,
          keyframe: bool = False) -> dict[str, Any]:
    """One stream frame as JPEG, or with `codec` "vp09" or "vp8" the session's next video
    packet at `bitrate` bits a second (render/video.py: the worker keeps the session's
    encoder; `keyframe` asks for a keyframe, and "key" says whether it is one); `slot`
    names the session whose scene pass is cached, and
    `hold_fog` keeps its time-invariant fog with it (stream/session.py decides when);
    `draft`, a preview, may be lit by the preview shadow map (render/passes/shadow.py).
    `show` other than "shaded" draws a view that teaches instead (render/teach.py), and
    its numbers and legend come back as "stats"."""
    from fogbank.render import teach
    from fogbank.render.encode import encode

    def fn(r):
        from fogbank.kinds.packing import uses_noise
        n = still.noise
        if uses_noise(still) and not r.noise.ready((n.size, n.octaves, n.blur, n.seed)):
            # its noise tile bakes on a thread meanwhile: the session asks again later, and
            # the worker draws other sessions' frames instead of waiting for the bake
            return {"pending": "noise", "render_ms": 0.0, "encode_ms": 0.0}
        t0 = time.perf_counter()
        stats, reused, warped = None, None, False
        work = (r.programs.compiled, r.noise.baked, r.shadows.new_suns)
        if show == "shaded":
            img = r.render(still, slot=slot, msaa=msaa, hold_fog=hold_fog, draft=draft, lend=True, channels=4)
            # a warped preview's scene pass is neither reused nor lost (its finished frame
            # warped leaves a part of one): the session learns nothing of its cache from it
            reused, warped = (None if r.scene_warped else r.scene_reused), r.scene_warped
        else:
            img, stats = teach.render(r, still, show, layer, slot=slot)
        t1 = time.perf_counter()
        key = False
        if codec == "jpeg":
            data = encode(img, "jpg", quality)
        else:
            data, key = _video().encode(slot, codec, img, bitrate, keyframe)
        return {"data": data, "render_ms": (t1 - t0) * 1000.0, "stats": stats, "key": key,
                "encode_ms": (time.perf_counter() - t1) * 1000.0,
                # it compiled a program, baked a noise tile or drew the full shadow map for a
                # sun new to the worker: work done once, not the look's cost (a dragged sun's
                # previews draw the preview map, which is their cost, as are the redraws of
                # suns whose maps evict each other: resources.SUNS_SEEN)
                "once": (r.programs.compiled, r.noise.baked, r.shadows.new_suns) != work,
                # whether it drew over the cached scene pass (None: a view that teaches)
                "scene_reused": reused,
                # whether it warped an earlier preview's (render/reproject.py)
                "scene_warped": warped}
    return _run(fn)


_VIDEO = None


def _video():
    """This worker's video encoders, by session (render/video.py)."""
    global _VIDEO
    if _VIDEO is None:
        from fogbank.render.video import VideoEncoders
        _VIDEO = VideoEncoders()
    return _VIDEO


def still(still, fmt: str) -> dict[str, Any]:
    """A still image, encoded as `fmt` (png, jpg, webp)."""
    from fogbank.render.encode import encode

    def fn(r):
        t0 = time.perf_counter()
        img = r.render(still, lend=True)
        t1 = time.perf_counter()
        data = encode(img, fmt)
        return {"data": data, "render_ms": (t1 - t0) * 1000.0,
                "encode_ms": (time.perf_counter() - t1) * 1000.0}
    return _run(fn)


def plot_ray(fog, x: float, y: float, width: int, height: int) -> dict[str, Any]:
    """The ray plot (model/ray_plot.py): float64 numpy, here so that it costs a worker's
    time, bounded by its deadline, and never the web process's."""
    from fogbank.model.ray_plot import plot_ray as plot

    def fn(r):
        return {"plot": plot(fog, x, y, width, height)}
    return _run(fn)


def transmittance(fog, origins: np.ndarray, directions: np.ndarray, lengths: np.ndarray,
                  times: np.ndarray) -> dict[str, Any]:
    def fn(r):
        return {"T": r.transmittance(fog, origins, directions, lengths, times)}
    return _run(fn)


def light(fog, origins: np.ndarray, directions: np.ndarray, lengths: np.ndarray,
          times: np.ndarray) -> dict[str, Any]:
    def fn(r):
        return r.light(fog, origins, directions, lengths, times)
    return _run(fn)


def noop() -> dict[str, Any]:
    """An empty job: what the process boundary alone costs (benchmark)."""
    return _run(lambda r: {})


def drop_slot(slot: str) -> dict[str, Any]:
    def fn(r):
        r.drop_slot(slot)
        if _VIDEO is not None:   # the session's video encoder goes with its scene pass
            _VIDEO.drop(slot)
        return {}
    return _run(fn)


def sleep(seconds: float) -> dict[str, Any]:
    """Holds the worker for `seconds` without yielding (a stand-in for a GL call that
    hangs; fault-injection tests use it). time.sleep would let a Python signal handler
    run; this does not matter here since SIGTERM is at its default action."""
    def fn(r):
        time.sleep(seconds)
        return {}
    return _run(fn)


def lose_context() -> dict[str, Any]:
    """Releases the worker's GL context, as a lost device would (fault-injection tests):
    this job fails and the worker rebuilds its renderer for the next one."""
    def fn(r):
        r.ctx.release()
        r.ctx.error  # raises: the context is gone
        return {}
    return _run(fn)
