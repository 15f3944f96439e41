"""Faults injected into a render worker process (run there as jobs, so they act on the
worker's own modules): each returns a dict, as every worker job does."""

from __future__ import annotations


def break_sphere_shaders() -> dict:
    """From now on, fog programs with a sphere layer fail to compile in this worker."""
    import fogbank.render.programs as programs
    real = programs.generated

    def broken(key, inline_particles=True):
        code = real(key, inline_particles)
        if any(k == "sphere" for k, _ in key):
            code["fog/layers.gen.glsl"] += "this is not GLSL;\n"
        return code
    programs.generated = broken
    return {}


def allocate(mb: int) -> dict:
    """Hold `mb` MiB of touched memory in this worker (for the memory-budget recycle)."""
    import numpy as np
    global _held
    _held = np.ones(mb << 18, dtype=np.float32)   # 4 bytes each
    from fogbank.workers import worker
    return worker._run(lambda r: {})


def spin(seconds: float) -> dict:
    """Keep this worker's CPU busy for `seconds` (a costly job, unlike worker.sleep's idle one)."""
    import time
    end = time.monotonic() + seconds
    x = 0
    while time.monotonic() < end:
        x += 1
    from fogbank.workers import worker
    return worker._run(lambda r: {"spins": x})
