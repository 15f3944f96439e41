"""The composite (Biri 4.2, Gawron 3.2): the scene colour mixed toward the fog colour by
the upsampled fog transmittance, with sun in-scattering, max opacity and the fused blur
(blur "single"), into the output; with blur "separate", into a linear target for the
blur pass."""

from __future__ import annotations

import moderngl
import numpy as np

from fogbank.model.fields import srgb_to_linear
from fogbank.render.gl import TEX, set_uniforms
from fogbank.render.passes.base import Pass
from fogbank.render.passes.output import output_defines, output_uniforms
from fogbank.render.passes.scene import draw_warp
from fogbank.render.passes.sky import sun_color
from fogbank.render.programs import FULLSCREEN
from fogbank.render.targets import FAR_LIST_WIDTH, SILHOUETTE_TILE

BLUR_MODES = {"off": 0, "single": 1, "separate": 2}
HELD_UNIFORMS = ("uFogColor", "uScatterColor", "uMaxOpacity", "uExposureScale", "uSkyAffect")
# and with aerial perspective, the sky's share of the fog's colour (its haze per pixel is
# kept: composite_held.glsl)
HELD_AERIAL_UNIFORMS = ("uAerial",)
# A held composite's 4x4 tile blends its fog bilinearly unless a pixel's kept depth-aware
# weight differs from its bilinear one by more than this (passes/held_edges.frag). At
# 1280x720 of the default look 0.01 leaves 16% of the tiles to the kept weights (0.002:
# 36%, 0.03: 10%). Against a held frame of full-resolution fog, over the 11 presets at
# fog scales 2 and 4, the pixels more than 8 levels off are as many as with the kept
# weights everywhere, and those more than 2 off within 3% of as many.
HELD_EDGE_WEIGHT = 0.01


def blur_sigma(f) -> float:
    """The blur's Gaussian sigma at full fog, in pixels (blur_radius is at 720 px high)."""
    return f.still.effects.blur_radius * f.still.height / 720.0


def held_inputs_key(f) -> tuple:
    """What the held composite's inputs depend on besides the held fog (and the scene pass
    it was drawn over): the in-scattering lobe's effects and the sky's haze (aerial
    perspective on or off, and the sky distance it depends on). The sky's share of fog is
    read each frame."""
    e = f.still.effects
    return (f.held_fog.key, e.phase, e.anisotropy, e.scatter_exponent, e.scatter_start,
            e.aerial_perspective > 0, e.sky_distance)


class CompositePass(Pass):
    """The composite of every pixel's near surface, then, over the tiles that hold one, of
    the pixels with two (passes/resolve.frag, passes/tiles.vert). A stream frame whose fog
    was drawn over a held fog (the camera still, passes/fog.py) takes the held composite
    for the near surfaces (unless the blur is fused): what depends on the scene and the
    held fog alone is drawn once (passes/composite_inputs.frag), and each frame blends the
    fog's moving texels (T, T toward the sun, in-scattered sunlight) (passes/composite_held.frag): by the kept depth-aware weights on
    the tiles that need them (passes/held_edges.frag), bilinearly on the others (the two
    draws split by a depth test against those marks: llvmpipe skips a 4x4 block that fails
    it; a branch would run both sides); its pixels with two surfaces are drawn packed and
    copied into place (_held_far)."""
    name = "composite"
    reads = ("gbuffer.color", "gbuffer.invdist", "gbuffer.sunlight", "gbuffer.far", "gbuffer.tiles",
             "gbuffer.held", "fog", "view", "gbuffer.out_base")
    writes = ("out", "linear", "gbuffer.held")

    def run(self, r, f) -> None:
        look, e, v = f.still, f.still.effects, f.view
        mode = BLUR_MODES[e.blur]
        sun = f.gbuffer.sunlight is not None
        g = f.gbuffer
        aerial = e.aerial_perspective > 0
        defines = dict(FOG_SCALE=e.fog_scale, BLUR_MODE=mode, SUN_LIGHT=int(sun), AERIAL=int(aerial),
                       **output_defines(look))
        held = f.held_fog is not None and mode != BLUR_MODES["single"]
        smooth = held and e.fog_scale > 1   # the held composite's bilinear draw
        if held:
            inputs = self._held_inputs(r, f, defines)
            progs = [r.programs.get(FULLSCREEN, "passes/composite_held.frag", SMOOTH=0, **defines)]
            if smooth:
                self._held_edges(r, f, f.held_fog, inputs.color_attachments[1])
                progs.append(r.programs.get(FULLSCREEN, "passes/composite_held.frag", SMOOTH=1, **defines))
        else:
            progs = [r.programs.get(FULLSCREEN, "passes/composite.frag", TWO_SURFACES=0, **defines)]
        n_held = len(progs) if held else 0   # the held composite's draws, which read few uniforms
        tiled = {"uViewport": np.array(f.targets.size, dtype=float), "uTileCols": g.tiles.width}
        if g.two_surfaces and held:   # the two-surface pixels packed, then put in place
            progs.append(r.programs.get(FULLSCREEN, "passes/composite.frag", TWO_SURFACES=1, HELD_NEAR=1,
                                        COMPACT=1, **defines))
            scatter = r.programs.get("passes/tiles.vert", "passes/far_scatter.frag", TILE=SILHOUETTE_TILE,
                                     FAR_LIST_WIDTH=FAR_LIST_WIDTH)
            set_uniforms(scatter, tiled)
        elif g.two_surfaces:
            progs.append(r.programs.get("passes/tiles.vert", "passes/composite.frag", TWO_SURFACES=1,
                                        TILE=SILHOUETTE_TILE, HELD_NEAR=0, **defines))
            set_uniforms(progs[-1], tiled)
        uniforms = {
            "uFwd": v.fwd, "uRight": v.right, "uUp": v.up,
            "uFogColor": np.array(srgb_to_linear(look.fog_color)),
            "uSunDir": look.sun.direction(),
            "uScatterColor": sun_color(look) * np.array(srgb_to_linear(e.scatter_color)) * e.scatter,
            "uScatterStart": e.scatter_start, "uSkyDistance": e.sky_distance, "uSkyAffect": e.sky_affect,
            "uScatterExponent": e.scatter_exponent, "uBlurSigma": blur_sigma(f),
            "uPhaseHG": e.phase == "henyey-greenstein", "uAnisotropy": e.anisotropy,
            "uMaxOpacity": e.max_opacity, "uBlurExponent": e.blur_exponent, "uAerial": e.aerial_perspective,
            **output_uniforms(look)}
        held_names = HELD_UNIFORMS + (HELD_AERIAL_UNIFORMS if aerial else ())
        for i, prog in enumerate(progs):
            # the held composite reads only the colours and the max opacity per frame
            set_uniforms(prog, {k: uniforms[k] for k in held_names} if i < n_held else uniforms)
        if held:   # the held composite and, for the near surface, the two-surface draw
            for name, tex in zip(("uHeldAB", "uHeldW"), inputs.color_attachments):
                tex.use(TEX[name])
        if mode == BLUR_MODES["single"]:
            g.mipmaps()   # the fused blur reads the scene's mip pyramid
        g.color.use(TEX["uColor"])
        g.invdist.use(TEX["uInvDist"])
        if sun:
            g.sunlight.use(TEX["uSunLight"])
        if g.two_surfaces:
            g.far_color.use(TEX["uFarColor"])
            g.far_invdist.use(TEX["uFarInvDist"])
            if sun:
                g.far_sunlight.use(TEX["uFarSunLight"])
        f.fog_tex.use(TEX["uFog"])
        target = f.targets.linear_pair()[0][0] if mode == BLUR_MODES["separate"] else f.targets.out
        if f.out_warp is not None:   # a preview's frame warped (blur off, never held): composited where unseen
            target = self._warp_out(r, f)
        if smooth:
            self._held_draws(r, f.held_fog, target, smooth=progs[1], kept=progs[0])
        else:
            target.use()
            r.programs.draw(progs[0], moderngl.TRIANGLES)
        if f.out_warp is not None:
            r.ctx.disable(moderngl.DEPTH_TEST)
        if g.two_surfaces:
            tiles, count = g.silhouette_tiles(r.ctx)
            if count:
                tiles.use(TEX["uTiles"])
                if held:
                    self._held_far(r, f, progs[-1], scatter, target, count, mode)
                else:
                    r.programs.draw(progs[-1], moderngl.TRIANGLES, vertices=6, instances=count)

    @staticmethod
    def _warp_out(r, f) -> moderngl.Framebuffer:
        """A preview's finished frame from the last one drawn whole (passes/warp_out.frag)
        into the output, its depth 0 where that one saw the ray; returns the output with
        that depth, the depth test on, for the composite to draw only where it is 1."""
        f.out_warp.source.color_attachments[0].use(TEX["uBaseOut"])
        fbo = f.targets.with_depth()
        fbo.use()
        # the composite's triangle (depth 0.5) then passes where the mask is 1
        draw_warp(r, r.programs.get(FULLSCREEN, "passes/warp_out.frag"), f.view, f.out_warp)
        return fbo

    @staticmethod
    def _held_far(r, f, compact, scatter, target, runs: int, mode: int) -> None:
        """The held composite's pixels with two surfaces: drawn packed into the held fog's
        list of them (render/targets.py HeldFog.far_pixels), every lane one of them, then
        copied into `target` over the `runs` of silhouette tiles (passes/far_scatter.frag,
        which finds each pixel's place from its tile's first place and mask)."""
        h = f.held_fog
        if h.far_count < 0:
            h.far_pixels(r.ctx, CompositePass._far_marks(r, f.gbuffer))
        if not h.far_count:
            return
        fbo, packed = h.far_target(r.ctx, "f2" if mode == BLUR_MODES["separate"] else "f1")
        h.far_list.use(TEX["uFarList"])
        fbo.use()
        r.programs.draw(compact, moderngl.TRIANGLES)
        target.use()
        h.far_tiles.use(TEX["uFarTiles"])
        packed.use(TEX["uFarOut"])
        r.programs.draw(scatter, moderngl.TRIANGLES, vertices=6, instances=runs)

    @staticmethod
    def _far_marks(r, g) -> np.ndarray:
        """(height, width) uint8, nonzero where a pixel sees two surfaces
        (passes/far_mask.frag), read back."""
        ctx, (w, h) = r.ctx, g.far_color.size
        marks = ctx.texture((w, h), 1)
        fbo = ctx.framebuffer(color_attachments=[marks])
        fbo.use()
        g.far_color.use(TEX["uFarColor"])
        r.programs.draw(r.programs.get(FULLSCREEN, "passes/far_mask.frag"), moderngl.TRIANGLES)
        out = np.frombuffer(fbo.read(components=1, alignment=1), np.uint8).reshape(h, w)
        r.caches.park()   # never release the bound framebuffer
        fbo.release()
        marks.release()
        return out

    @staticmethod
    def _held_draws(r, h, target, smooth, kept) -> None:
        """The held composite's two draws into `target`'s colour: bilinear where the held
        fog's edge marks lie behind a fullscreen triangle, by the kept weights where they lie
        in front (passes/held_edges_depth.frag)."""
        ctx = r.ctx
        fbo = ctx.framebuffer(color_attachments=target.color_attachments, depth_attachment=h.edges)
        fbo.depth_mask = False
        fbo.use()
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        r.programs.draw(smooth, moderngl.TRIANGLES)
        ctx.depth_func = ">"
        r.programs.draw(kept, moderngl.TRIANGLES)
        ctx.depth_func = "<"
        ctx.disable(moderngl.DEPTH_TEST)
        target.use()   # before the release: never release the bound framebuffer
        fbo.release()

    @staticmethod
    def _held_edges(r, f, h, weights) -> None:
        """Mark, in the held fog's depth buffer `edges`, the tiles where the kept weights are
        not bilinear (passes/held_edges.frag), then write them as depths
        (passes/held_edges_depth.frag); once per held fog."""
        edges = h.edge_marks(r.ctx)
        if h.edges_key == h.key:
            return
        ctx, (w, hgt), tile = r.ctx, f.targets.size, SILHOUETTE_TILE
        marks = ctx.texture((-(-w // tile), -(-hgt // tile)), 1)
        marks.filter = (moderngl.NEAREST, moderngl.NEAREST)
        marks_fbo = ctx.framebuffer(color_attachments=[marks])
        prog = r.programs.get(FULLSCREEN, "passes/held_edges.frag", FOG_SCALE=f.still.effects.fog_scale,
                              TILE=tile, EDGE_WEIGHT=HELD_EDGE_WEIGHT)
        weights.use(TEX["uHeldW"])
        marks_fbo.use()
        r.programs.draw(prog, moderngl.TRIANGLES)
        depth_fbo = ctx.framebuffer(depth_attachment=edges)
        depth_fbo.use()
        marks.use(TEX["uEdges"])
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = "1"   # always: every pixel's mark
        r.programs.draw(r.programs.get(FULLSCREEN, "passes/held_edges_depth.frag", TILE=tile), moderngl.TRIANGLES)
        ctx.depth_func = "<"
        ctx.disable(moderngl.DEPTH_TEST)
        r.caches.park()   # never release the bound framebuffer
        depth_fbo.release()
        marks_fbo.release()
        marks.release()
        h.edges_key = h.key

    @staticmethod
    def _held_inputs(r, f, defines: dict):
        """The held composite's inputs over the frame's held fog, drawn if what they depend
        on changed (held_inputs_key): the still scene pass, and the fog target's 1/distance,
        which is the held fog's."""
        look, e, v, g = f.still, f.still.effects, f.view, f.gbuffer
        h = f.held_fog
        key = held_inputs_key(f)
        fbo = h.composite_inputs(r.ctx, f.targets.size)
        if h.inputs_key == key:
            return fbo
        prog = r.programs.get(FULLSCREEN, "passes/composite_inputs.frag", FOG_SCALE=e.fog_scale,
                              SUN_LIGHT=defines["SUN_LIGHT"], AERIAL=defines["AERIAL"])
        set_uniforms(prog, {"uFwd": v.fwd, "uRight": v.right, "uUp": v.up, "uSunDir": look.sun.direction(),
                            "uScatterStart": e.scatter_start, "uSkyDistance": e.sky_distance,
                            "uScatterExponent": e.scatter_exponent,
                            "uPhaseHG": e.phase == "henyey-greenstein", "uAnisotropy": e.anisotropy})
        g.color.use(TEX["uColor"])
        g.invdist.use(TEX["uInvDist"])
        if g.sunlight is not None:
            g.sunlight.use(TEX["uSunLight"])
        f.fog_tex.use(TEX["uFog"])
        fbo.use()
        r.programs.draw(prog, moderngl.TRIANGLES)
        h.inputs_key = key
        return fbo
