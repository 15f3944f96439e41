"""The transmittance API's draws: T of arbitrary rays by the same fog GLSL as frames,
apart from the frame passes. Rays are drawn in groups sharing a time (the particle state
depends on it) and an origin (the layers are packed relative to it, as a frame's are to
its eye), one draw per group into one target."""

from __future__ import annotations

import moderngl
import numpy as np

from fogbank.kinds.packing import variant
from fogbank.render.frame import plan_fog
from fogbank.render.gl import TEX, release_fbo, set_uniforms
from fogbank.render.passes.fog import bind_fog

RAYS_PER_ROW = 1024


class RayCaster:
    def __init__(self, r):
        self.r = r
        self._targets: tuple | None = None

    def _targets_for(self, rows: int):
        """Ray input texture and output target with room for `rows` rows (kept and
        reused; grown by powers of two)."""
        if self._targets is None or self._targets[0] < rows:
            ctx = self.r.ctx
            cap = 1 << max(0, (rows - 1).bit_length())
            if self._targets is not None:
                self.r.caches.park()
                _, old_rays, _, old_fbo = self._targets
                release_fbo(old_fbo)   # the framebuffer first, then its target texture
                old_rays.release()
            rays = ctx.texture((RAYS_PER_ROW, cap), 4, dtype="f4")
            rays.filter = (moderngl.NEAREST, moderngl.NEAREST)
            target = ctx.texture((RAYS_PER_ROW, cap), 1, dtype="f4")
            fbo = ctx.framebuffer(color_attachments=[target])
            self._targets = (cap, rays, target, fbo)
        return self._targets

    def transmittance(self, fog, origins, directions, lengths, times) -> np.ndarray:
        """T of each ray by the fog GLSL (float32)."""
        r = self.r
        O = np.asarray(origins, dtype=np.float64).reshape(-1, 3)
        W = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
        D = np.asarray(lengths, dtype=np.float64).reshape(-1)
        t = np.asarray(times, dtype=np.float64).reshape(-1)
        n = len(D)
        groups, inverse = np.unique(np.column_stack([t, O]), axis=0, return_inverse=True)
        order = np.argsort(inverse.reshape(-1), kind="stable")   # rays of a group contiguous
        starts = np.searchsorted(inverse.reshape(-1)[order], np.arange(len(groups) + 1))
        rows = -(-n // RAYS_PER_ROW)
        _, rays, _, fbo = self._targets_for(rows)
        data = np.zeros((rows * RAYS_PER_ROW, 4), np.float32)
        data[:n, :3], data[:n, 3] = W[order], D[order]
        rays.write(data.tobytes(), viewport=(0, 0, RAYS_PER_ROW, rows))
        fbo.use()
        prog = r.programs.get("passes/fullscreen.vert", "passes/rays.frag", variant(fog),
                              RAYS_PER_ROW=RAYS_PER_ROW)
        rays.use(TEX["uRays"])
        for g, (tval, *ref) in enumerate(groups):
            lo, hi = int(starts[g]), int(starts[g + 1])
            bind_fog(r, prog, plan_fog(fog, float(tval), np.array(ref), r.sims))
            set_uniforms(prog, {"uFirst": lo, "uCount": hi - lo})
            r0, r1 = lo // RAYS_PER_ROW, (hi - 1) // RAYS_PER_ROW + 1
            if r1 - r0 == 1:   # within one row: just its span (no fragments to discard)
                fbo.viewport = (lo % RAYS_PER_ROW, r0, hi - lo, 1)
            else:
                fbo.viewport = (0, r0, RAYS_PER_ROW, r1 - r0)
            r.programs.draw(prog, moderngl.TRIANGLES)
        fbo.viewport = (0, 0, RAYS_PER_ROW, rows)
        res = np.frombuffer(fbo.read(viewport=(0, 0, RAYS_PER_ROW, rows), components=1, dtype="f4",
                                     alignment=1), np.float32)
        out = np.empty(n, np.float32)
        out[order] = res[:n]
        return out

