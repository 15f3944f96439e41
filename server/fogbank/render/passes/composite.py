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

BLUR_MODES = {"off": 0, "single": 1, "separate": 2}


def blur_sigma(f) -> float:
    """The blur's Gaussian sigma at full fog, in pixels (blur_radius is at 720 px high)."""
    return f.still.effects.blur_radius * f.still.height / 720.0


class CompositePass(Pass):
    name = "composite"
    reads = ("gbuffer.color", "gbuffer.invdist", "gbuffer.sunlight", "fog", "view")
    writes = ("out", "linear")

    def run(self, r, f) -> None:
        look, e, v = f.still, f.still.effects, f.view
        mode = BLUR_MODES[e.blur]
        sun = f.gbuffer.sunlight is not None
        prog = r.programs.get("passes/fullscreen.vert", "passes/composite.frag",
                              FOG_SCALE=e.fog_scale, BLUR_MODE=mode, SUN_LIGHT=int(sun))
        set_uniforms(prog, {
            "uFwd": v.fwd, "uRight": v.right, "uUp": v.up,
            "uFogColor": np.array(srgb_to_linear(look.fog_color)),
            "uSunDir": look.sun.direction(),
            "uScatterColor": sun_color(look) * np.array(srgb_to_linear(e.scatter_color)) * e.scatter,
            "uScatterStart": e.scatter_start, "uSkyDistance": e.sky_distance,
            "uScatterExponent": e.scatter_exponent, "uBlurSigma": blur_sigma(f),
            "uPhaseHG": e.phase == "henyey-greenstein", "uAnisotropy": e.anisotropy,
            "uShafts": e.shafts,
            "uMaxOpacity": e.max_opacity, "uBlurExponent": e.blur_exponent})
        if mode == BLUR_MODES["single"]:
            f.gbuffer.mipmaps()   # the fused blur reads the scene's mip pyramid
        f.gbuffer.color.use(TEX["uColor"])
        f.gbuffer.invdist.use(TEX["uInvDist"])
        if sun:
            f.gbuffer.sunlight.use(TEX["uSunLight"])
        f.fog_tex.use(TEX["uFog"])
        if mode == BLUR_MODES["separate"]:
            f.targets.linear_pair()[0][0].use()
        else:
            f.targets.out.use()
        r.programs.draw(prog, moderngl.TRIANGLES)
