"""The transmittance and light APIs' draws: T of arbitrary rays by the same fog GLSL as
frames, and the light its fog scatters (passes/light.frag LIGHT_RAYS), apart from the
frame passes. Rays are drawn in groups sharing a time (the particle state
depends on it) and an origin (the layers are packed relative to it, as a frame's are to
its eye), one draw per group into one target."""

from __future__ import annotations

import moderngl
import numpy as np

from fogbank.kinds.packing import variant
from fogbank.model.fields import srgb_to_linear
from fogbank.render.frame import plan_fog
from fogbank.render.gl import TEX, release_fbo, set_uniforms
from fogbank.render.passes.fog import bind_fog
from fogbank.render.passes.light import LIGHT_CURVE_M, LIGHT_QUALITY
from fogbank.render.passes.shadow import shadow_map, sun_view_proj
from fogbank.render.passes.sky import sun_color

RAYS_PER_ROW = 1024
LIGHT_RAY_SLICES = 128   # slices of each ray of the light endpoint (passes/light.frag LIGHT_RAYS)


class RayCaster:
    def __init__(self, r):
        self.r = r
        self._targets: tuple | None = None
        self._outputs = 1

    def _targets_for(self, rows: int, outputs: int = 1):
        """Ray input texture and output target with room for `rows` rows: one R32F
        output, or `outputs` RGBA32F (kept and reused; grown by powers of two)."""
        if self._targets is None or self._targets[0] < rows or self._outputs != outputs:
            ctx = self.r.ctx
            cap = 1 << max(0, (rows - 1).bit_length())
            if self._targets is not None:
                self.r.caches.park()
                _, old_rays, _, old_fbo = self._targets
                release_fbo(old_fbo)   # the framebuffer first, then its target textures
                old_rays.release()
            rays = ctx.texture((RAYS_PER_ROW, cap), 4, dtype="f4")
            rays.filter = (moderngl.NEAREST, moderngl.NEAREST)
            targets = [ctx.texture((RAYS_PER_ROW, cap), 1 if outputs == 1 else 4, dtype="f4") for _ in range(outputs)]
            fbo = ctx.framebuffer(color_attachments=targets)
            self._targets = (cap, rays, targets, fbo)
            self._outputs = outputs
        return self._targets

    def transmittance(self, fog, origins, directions, lengths, times) -> np.ndarray:
        """T of each ray by the fog GLSL (float32)."""
        prog = self.r.programs.get("passes/fullscreen.vert", "passes/rays.frag", variant(fog),
                                   RAYS_PER_ROW=RAYS_PER_ROW)
        return self._draw(fog, prog, origins, directions, lengths, times, 1)[0][:, 0]

    def light(self, fog, origins, directions, lengths, times) -> dict[str, np.ndarray]:
        """Each ray's light by passes/light.frag (LIGHT_RAYS, float32): "T" as
        transmittance(), "J" the sunlight its fog scatters toward the origin (a share of the
        sun's in-scattering, 0 to 1 - T), "T_medium" the fog's own transmittance (no cutoff
        distance or max opacity) and "light" the fog's linear RGB light along it, as the
        composite adds it (passes/composite_parts.glsl fogLight). Every layer is marched
        over LIGHT_RAY_SLICES slices of each ray (particles too, their clarity toward the
        origin; their own light is a frame's quads'); the fog toward the sun is the density
        layers' (effects.lit), and with shafts the look's scene shadows it through its
        shadow map."""
        r, e = self.r, fog.effects
        taps = LIGHT_QUALITY["high"][2] if e.shafts > 0 else 0
        extra = {"SUN_THROUGH_FOG": 1} if e.lit else {}
        prog = r.programs.get("passes/fullscreen.vert", "passes/light.frag", variant(fog), inline_particles=True,
                              RAYS_PER_ROW=RAYS_PER_ROW, LIGHT_RAYS=1, SLICES=LIGHT_RAY_SLICES, SHADOW_TAPS=taps,
                              LIT=int(e.lit), LIGHT_STAGE=0, LIGHT_CURVE_M=f"{LIGHT_CURVE_M:.1f}",
                              AERIAL=int(e.aerial_perspective > 0), **extra)
        set_uniforms(prog, {"uSlices": LIGHT_RAY_SLICES, "uSunDir": fog.sun.direction(), "uSkyDistance": e.sky_distance,
                            "uFogColor": np.array(srgb_to_linear(fog.fog_color)),
                            "uScatterColor": sun_color(fog) * np.array(srgb_to_linear(e.scatter_color)) * e.scatter,
                            "uScatterExponent": e.scatter_exponent, "uScatterStart": e.scatter_start,
                            "uPhaseHG": e.phase == "henyey-greenstein", "uAnisotropy": e.anisotropy,
                            "uMaxOpacity": e.max_opacity, "uAerial": e.aerial_perspective})
        if taps:
            sm = shadow_map(r, fog)
            set_uniforms(prog, {"uSunViewProj": sun_view_proj(r, fog), "uShafts": e.shafts,
                                "uShadowBiasScale": sm.bias_scale})
            sm.nearest.use(TEX["uShadow"])
        out, light = self._draw(fog, prog, origins, directions, lengths, times, 2, eye=bool(taps))
        if taps:
            sm.nearest.clear(TEX["uShadow"])
        return {"T": out[:, 0], "J": out[:, 1], "T_medium": out[:, 2], "light": light[:, :3]}

    def _draw(self, fog, prog, origins, directions, lengths, times, outputs: int, eye: bool = False):
        """Draw `prog` over the rays, in groups by time and origin; its `outputs` RGBA32F
        outputs (the first R32F for one output), each ray's row in the rays' order. `eye`:
        the program takes the group's origin as uEye (a shadow map in world space)."""
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
        _, rays, _, fbo = self._targets_for(rows, outputs)
        data = np.zeros((rows * RAYS_PER_ROW, 4), np.float32)
        data[:n, :3], data[:n, 3] = W[order], D[order]
        rays.write(data.tobytes(), viewport=(0, 0, RAYS_PER_ROW, rows))
        fbo.use()
        rays.use(TEX["uRays"])
        for g, (tval, *ref) in enumerate(groups):
            lo, hi = int(starts[g]), int(starts[g + 1])
            bind_fog(r, prog, plan_fog(fog, float(tval), np.array(ref), r.sims))
            set_uniforms(prog, {"uFirst": lo, "uCount": hi - lo, **({"uEye": np.array(ref)} if eye else {})})
            r0, r1 = lo // RAYS_PER_ROW, (hi - 1) // RAYS_PER_ROW + 1
            if r1 - r0 == 1:   # within one row: just its span (no fragments to discard)
                fbo.viewport = (lo % RAYS_PER_ROW, r0, hi - lo, 1)
            else:
                fbo.viewport = (0, r0, RAYS_PER_ROW, r1 - r0)
            r.programs.draw(prog, moderngl.TRIANGLES)
        fbo.viewport = (0, 0, RAYS_PER_ROW, rows)
        results = []
        for k in range(outputs):
            c = 1 if outputs == 1 else 4
            res = np.frombuffer(fbo.read(viewport=(0, 0, RAYS_PER_ROW, rows), components=c, dtype="f4",
                                         alignment=1, attachment=k), np.float32).reshape(-1, c)
            out = np.empty((n, c), np.float32)
            out[order] = res[:n]
            results.append(out)
        return results

