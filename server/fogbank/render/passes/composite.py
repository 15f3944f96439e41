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


def blur_sigma(f) -> float:
    """The blur's Gaussian sigma at full fog, in pixels (blur_radius is at 720 px high)."""
    return f.still.effects.blur_radius * f.still.height / 720.0


class CompositePass(Pass):
    name = "composite"
    reads = ("gbuffer.color", "gbuffer.invdist", "gbuffer.sunlight", "gbuffer.far", "gbuffer.tiles", "fog", "view")
    writes = ("out", "linear")

    def run(self, r, f) -> None:
        look, e, v = f.still, f.still.effects, f.view
        mode = BLUR_MODES[e.blur]
        sun = f.gbuffer.sunlight is not None
        g = f.gbuffer
        # every pixel's near surface; then, over the tiles that hold one, the pixels with two
        # (passes/resolve.frag, passes/tiles.vert)
        defines = dict(FOG_SCALE=e.fog_scale, BLUR_MODE=mode, SUN_LIGHT=int(sun))
        progs = [r.programs.get(FULLSCREEN, "passes/composite.frag", TWO_SURFACES=0, **defines)]
        if g.two_surfaces:
            progs.append(r.programs.get("passes/tiles.vert", "passes/composite.frag", TWO_SURFACES=1,
                                        TILE=SILHOUETTE_TILE, **defines))
            set_uniforms(progs[1], {"uViewport": np.array(f.targets.size, dtype=float)})
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
        for prog in progs:
            set_uniforms(prog, uniforms)
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
            g.tiles.use(TEX["uTiles"])
            r.programs.draw(progs[1], moderngl.TRIANGLES, vertices=6, instances=g.tiles.width * g.tiles.height)
