"""The MSAA resolve (passes/resolve.frag): each pixel's samples split into its near and
far surface, each averaged alone, into the slot's G-buffer, so that the composite fogs
each surface at its own distance. Runs with the scene pass (cached with it); a preview
draws straight into the G-buffer and has nothing to resolve."""

from __future__ import annotations

import moderngl

from fogbank.render.gl import TEX
from fogbank.render.passes.base import Pass
from fogbank.render.passes.sky import scene_target
from fogbank.render.programs import FULLSCREEN
from fogbank.render.targets import MSAA_SAMPLES, SILHOUETTE_TILE


class ResolvePass(Pass):
    name = "resolve"
    reads = ("scene_target",)
    writes = ("gbuffer.color", "gbuffer.invdist", "gbuffer.sunlight", "gbuffer.far", "gbuffer.tiles")

    def run(self, r, f) -> None:
        g = f.gbuffer
        if f.scene_cached:
            return
        if not f.msaa:
            g.two_surfaces = False
            return
        sun = g.sunlight is not None
        prog = r.programs.get(FULLSCREEN, "passes/resolve.frag", SAMPLES=MSAA_SAMPLES, SUN_LIGHT=int(sun))
        target = scene_target(f)
        for name, tex in zip(("uColor", "uInvDist", "uSunLight"), target.color_attachments):
            tex.use(TEX[name])
        g.resolve_fbo.use()
        r.ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
        r.programs.draw(prog, moderngl.TRIANGLES)
        # the tiles that hold a pixel with two surfaces, for the composite's second draw
        tiles = r.programs.get(FULLSCREEN, "passes/silhouette_tiles.frag", TILE=SILHOUETTE_TILE)
        g.far_color.use(TEX["uFarColor"])
        g.tiles_fbo.use()
        r.programs.draw(tiles, moderngl.TRIANGLES)
        g.tile_count = -1   # listed when the composite first asks (GBuffer.silhouette_tiles)
        g.two_surfaces = True
