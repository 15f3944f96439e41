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
from fogbank.render.passes.sky import sun_color
from fogbank.render.programs import FULLSCREEN
from fogbank.render.targets import SILHOUETTE_TILE

BLUR_MODES = {"off": 0, "single": 1, "separate": 2}
HELD_UNIFORMS = ("uFogColor", "uScatterColor", "uMaxOpacity")


def blur_sigma(f) -> float:
    """The blur's Gaussian sigma at full fog, in pixels (blur_radius is at 720 px high)."""
    return f.still.effects.blur_radius * f.still.height / 720.0


def held_inputs_key(f) -> tuple:
    """What the held composite's inputs depend on besides the held fog (and the scene pass
    it was drawn over): the in-scattering lobe's effects and the sky's share of fog."""
    e = f.still.effects
    return (f.held_fog.key, e.phase, e.anisotropy, e.scatter_exponent, e.scatter_start, e.shafts, e.sky_affect)


class CompositePass(Pass):
    """The composite of every pixel's near surface, then, over the tiles that hold one, of
    the pixels with two (passes/resolve.frag, passes/tiles.vert). A stream frame whose fog
    was drawn over a held fog (the camera still, passes/fog.py) takes the held composite
    for the near surfaces (unless the blur is fused): what depends on the scene and the
    held fog alone is drawn once (passes/composite_inputs.frag), and each frame blends the
    fog's moving texels (passes/composite_held.frag)."""
    name = "composite"
    reads = ("gbuffer.color", "gbuffer.invdist", "gbuffer.sunlight", "gbuffer.far", "gbuffer.tiles",
             "gbuffer.held", "fog", "view")
    writes = ("out", "linear", "gbuffer.held")

    def run(self, r, f) -> None:
        look, e, v = f.still, f.still.effects, f.view
        mode = BLUR_MODES[e.blur]
        sun = f.gbuffer.sunlight is not None
        g = f.gbuffer
        defines = dict(FOG_SCALE=e.fog_scale, BLUR_MODE=mode, SUN_LIGHT=int(sun))
        held = f.held_fog is not None and mode != BLUR_MODES["single"]
        if held:
            inputs = self._held_inputs(r, f, defines)
            progs = [r.programs.get(FULLSCREEN, "passes/composite_held.frag", **defines)]
        else:
            progs = [r.programs.get(FULLSCREEN, "passes/composite.frag", TWO_SURFACES=0, **defines)]
        if g.two_surfaces:
            progs.append(r.programs.get("passes/tiles.vert", "passes/composite.frag", TWO_SURFACES=1,
                                        TILE=SILHOUETTE_TILE, HELD_NEAR=int(held), **defines))
            set_uniforms(progs[1], {"uViewport": np.array(f.targets.size, dtype=float), "uTileCols": g.tiles.width})
        uniforms = {
            "uFwd": v.fwd, "uRight": v.right, "uUp": v.up,
            "uFogColor": np.array(srgb_to_linear(look.fog_color)),
            "uSunDir": look.sun.direction(),
            "uScatterColor": sun_color(look) * np.array(srgb_to_linear(e.scatter_color)) * e.scatter,
            "uScatterStart": e.scatter_start, "uSkyDistance": e.sky_distance, "uSkyAffect": e.sky_affect,
            "uScatterExponent": e.scatter_exponent, "uBlurSigma": blur_sigma(f),
            "uPhaseHG": e.phase == "henyey-greenstein", "uAnisotropy": e.anisotropy,
            "uShafts": e.shafts,
            "uMaxOpacity": e.max_opacity, "uBlurExponent": e.blur_exponent}
        for i, prog in enumerate(progs):
            # the held composite reads only the colours and the max opacity per frame
            set_uniforms(prog, {k: uniforms[k] for k in HELD_UNIFORMS} if held and i == 0 else uniforms)
        if held:   # the held composite and, for the near surface, the two-surface draw
            for name, tex in zip(("uHeldA", "uHeldB", "uHeldW"), inputs.color_attachments):
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
        if mode == BLUR_MODES["separate"]:
            f.targets.linear_pair()[0][0].use()
        else:
            f.targets.out.use()
        r.programs.draw(progs[0], moderngl.TRIANGLES)
        if g.two_surfaces:
            tiles, count = g.silhouette_tiles(r.ctx)
            if count:
                tiles.use(TEX["uTiles"])
                r.programs.draw(progs[1], moderngl.TRIANGLES, vertices=6, instances=count)

    @staticmethod
    def _held_inputs(r, f, defines: dict):
        """The held composite's inputs over the frame's held fog, drawn if what they depend
        on changed (held_inputs_key): the still scene pass, and the fog target's 1/distance
        and lit share, which are the held fog's."""
        look, e, v, g = f.still, f.still.effects, f.view, f.gbuffer
        h = f.held_fog
        key = held_inputs_key(f)
        fbo = h.composite_inputs(r.ctx, f.targets.size)
        if h.inputs_key == key:
            return fbo
        prog = r.programs.get(FULLSCREEN, "passes/composite_inputs.frag", FOG_SCALE=e.fog_scale,
                              SUN_LIGHT=defines["SUN_LIGHT"])
        set_uniforms(prog, {"uFwd": v.fwd, "uRight": v.right, "uUp": v.up, "uSunDir": look.sun.direction(),
                            "uScatterStart": e.scatter_start, "uSkyDistance": e.sky_distance,
                            "uSkyAffect": e.sky_affect, "uScatterExponent": e.scatter_exponent,
                            "uPhaseHG": e.phase == "henyey-greenstein", "uAnisotropy": e.anisotropy,
                            "uShafts": e.shafts})
        g.color.use(TEX["uColor"])
        g.invdist.use(TEX["uInvDist"])
        if g.sunlight is not None:
            g.sunlight.use(TEX["uSunLight"])
        f.fog_tex.use(TEX["uFog"])
        fbo.use()
        r.programs.draw(prog, moderngl.TRIANGLES)
        h.inputs_key = key
        return fbo
