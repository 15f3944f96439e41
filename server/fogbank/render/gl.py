"""The GL context and the small helpers every pass uses: texture units, a uniform setter
that refuses a name its program does not declare, and framebuffer release."""

from __future__ import annotations

import os

import moderngl
import numpy as np

from fogbank.render.glsl import ShaderError

# texture units, fixed per sampler name across every program
TEX = {"uColor": 0, "uInvDist": 1, "uFog": 2, "uParticles": 3, "uNoise": 4, "uShadow": 5,
       "uRays": 6, "uImage": 0, "uSunLight": 7, "uFarColor": 8, "uFarInvDist": 9, "uFarSunLight": 10,
       "uTiles": 11, "uLightmap": 12, "uHeld": 13, "uHeldDirect": 14,
       "uHeldAB": 15, "uFarList": 16, "uHeldW": 17, "uEdges": 18, "uFarTiles": 19, "uFarOut": 20,
       "uLightGrid": 21, "uSlices4": 22, "uHeldLight": 23,
       # the warp (passes/warp.frag) reads the warp base, never the G-buffer it draws into
       "uBaseColor": 0, "uBaseInvDist": 1, "uBaseSunLight": 7, "uBaseOut": 25}


def usable_cores() -> int:
    """The cores this process may run on (its affinity), else the machine's."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def raster_threads(workers: int = 1) -> int:
    """llvmpipe's raster threads for each of `workers` render processes: one more than
    its share of this process's cores. llvmpipe's default is one per core; the thread that
    submits the draws (vertex shading, triangle setup) then waits on the raster threads at
    every change of target, and a small frame's passes (a 320x180 preview has ten) leave a
    core idle at each. One more: a 320x180 preview of the default look went from 16.1 to
    12.1 ms (medians of 30 frames, five rounds alternated), 448x252 from 22.7 to 19.2; no
    difference to measure at 640x360 and 1280x720 on this 2-core machine."""
    return max(1, usable_cores() // max(1, workers)) + 1


def create_context(backend: str = "auto", device: int | None = None, threads: int = 0) -> moderngl.Context:
    """A standalone context on EGL (GPU if the EGL device is one, else Mesa llvmpipe).
    `threads`: llvmpipe's raster threads (LP_NUM_THREADS, read when the first context of
    the process is made), 0 for raster_threads(); an LP_NUM_THREADS already set wins, and
    a GPU ignores it."""
    os.environ.setdefault("LP_NUM_THREADS", str(threads or raster_threads()))
    if backend == "default":
        ctx = moderngl.create_context(standalone=True, require=330)
    else:
        kwargs = {"device_index": device} if device is not None else {}
        ctx = moderngl.create_context(standalone=True, backend="egl", require=330, **kwargs)
    check_extensions(ctx)
    return ctx


# GL 3.3 with these (core in later GL versions, and listed by every GL 4 driver and Mesa's
# llvmpipe): the held composite packs its inputs as halves (passes/composite_inputs.frag).
# The shaders are GLSL 3.30 and name the extension, so a later context must list it too.
REQUIRED_EXTENSIONS = ("GL_ARB_shading_language_packing",)


def check_extensions(ctx: moderngl.Context) -> None:
    """Fail at start, naming what is missing, rather than at a stream's first held frame."""
    missing = [name for name in REQUIRED_EXTENSIONS if name not in ctx.extensions]
    if missing:
        raise RuntimeError(f"the GL context ({ctx.info.get('GL_RENDERER')}, {ctx.version_code}) lacks "
                           f"{', '.join(missing)}, which fogbank's shaders need")


def set_uniform(prog, name: str, value) -> None:
    """Set a uniform. A name the program's source does not declare is a bug in the pass
    and raises; a declared one the compiler optimised away (unused in this variant) is
    skipped."""
    declared = prog.extra["declared"]
    if name not in declared:
        raise ShaderError(f"{prog.extra['name']}: sets uniform {name!r}, which its source does "
                          f"not declare (it declares {', '.join(sorted(declared))})")
    if name not in prog:
        return
    u = prog[name]
    if isinstance(value, np.ndarray) and value.ndim == 2 and value.shape == (4, 4):
        u.write(value.T.astype("f4").tobytes())  # GL matrices are column-major
    elif isinstance(value, np.ndarray):
        u.value = tuple(float(v) for v in value)
    else:
        u.value = value


def set_uniforms(prog, values: dict) -> None:
    for name, value in values.items():
        set_uniform(prog, name, value)


def release_fbo(fbo: moderngl.Framebuffer | None) -> None:
    """Release a framebuffer and everything attached to it (renderbuffers and textures):
    releasing the framebuffer alone leaves its attachments allocated."""
    if fbo is None:
        return
    attachments = list(fbo.color_attachments) + [fbo.depth_attachment]
    fbo.release()
    for a in attachments:
        if a is not None:
            a.release()
