"""Benchmark hooks, apart from the frame: the scene passes (cached) and the fog pass
alone, timed, with its raw output read back."""

from __future__ import annotations

import time

import numpy as np

from fogbank.render.passes import (FogFilterPass, FogPass, LightPass, ParticlesPass, ResolvePass, ScenePass,
                                   ShadowPass, SkyPass)


def fog_only(r, still, raymarch_steps: int | None = None, read: bool = True, filtered: bool = False):
    """The scene passes (cached, slot "bench") and the fog pass (with the particle quads)
    alone: milliseconds, and with `read` the raw transmittance and inverse distance per
    fog texel, bottom row first, and the view. With raymarch_steps, the exponential
    layers are raymarched instead of integrated in closed form. The time covers the GL
    work of the fog and particle passes (uploads included), not the fog plan's CPU work
    (packing, particle simulation), which runs on the preparation thread before it. With
    `filtered`, the jittered fog's filter pass runs between them, as in a frame."""
    ms, f = fog_frame(r, still, raymarch_steps, filtered)
    if not read:
        return ms
    a = fog_texels(f)
    return ms, a[..., 0].copy(), a[..., 1].copy(), f.view


def fog_frame(r, still, raymarch_steps: int | None = None, filtered: bool = False, slot: str = "bench"):
    """(milliseconds of the fog and particle passes, the frame) after the scene passes,
    cached in `slot`."""
    f = r.begin(still, slot=slot, msaa=True)
    f.raymarch_steps = raymarch_steps
    for p in (ShadowPass(), ScenePass(), SkyPass(), ResolvePass()):
        p.run(r, f)
    f.fog_plan()
    r.ctx.finish()
    t0 = time.perf_counter()
    for p in (LightPass(), FogPass(), *([FogFilterPass()] if filtered else []), ParticlesPass()):
        p.run(r, f)
    r.ctx.finish()
    return (time.perf_counter() - t0) * 1000.0, f


def fog_texels(f) -> np.ndarray:
    """A drawn frame's fog target, bottom row first: (raw T, 1/distance, T toward the sun,
    in-scattered sunlight J) per texel."""
    tex = f.fog_tex
    return np.frombuffer(tex.read(), np.float32).reshape(tex.height, tex.width, tex.components)


def fog_target(r, still, filtered: bool = False) -> np.ndarray:
    """fog_only's passes, then the whole fog target (fog_texels)."""
    return fog_texels(fog_frame(r, still, filtered=filtered)[1])
