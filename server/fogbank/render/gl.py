"""The GL context and the small helpers every pass uses: texture units, a uniform setter
that refuses a name its program does not declare, and framebuffer release."""

from __future__ import annotations

import moderngl
import numpy as np

from fogbank.render.glsl import ShaderError

# texture units, fixed per sampler name across every program
TEX = {"uColor": 0, "uInvDist": 1, "uFog": 2, "uParticles": 3, "uNoise": 4, "uShadow": 5,
       "uRays": 6, "uImage": 0, "uSunLight": 7, "uFarColor": 8, "uFarInvDist": 9, "uFarSunLight": 10,
       "uTiles": 11, "uLightmap": 12, "uHeld": 13, "uHeldDirect": 14,
       "uHeldA": 15, "uHeldB": 16, "uHeldW": 17}


def create_context(backend: str = "auto", device: int | None = None) -> moderngl.Context:
    """A standalone context on EGL (GPU if the EGL device is one, else Mesa llvmpipe)."""
    if backend == "default":
        return moderngl.create_context(standalone=True, require=330)
    kwargs = {"device_index": device} if device is not None else {}
    return moderngl.create_context(standalone=True, backend="egl", require=330, **kwargs)


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
