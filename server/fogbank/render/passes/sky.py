"""The sky behind the scene: a fullscreen triangle into the scene target (MSAA or the
G-buffer), with the sun's disc and glow (common/sky.glsl)."""

from __future__ import annotations

import moderngl
import numpy as np

from fogbank.model.fields import srgb_to_linear
from fogbank.render.gl import set_uniforms
from fogbank.render.passes.base import Pass
from fogbank.scene.meshes import CALIBRATION_SKY


def scene_target(f):
    """Where the sky and the scene are drawn: the MSAA target, resolved into the
    G-buffer by the scene pass, or the G-buffer itself for a preview."""
    return f.targets.msaa(f.gbuffer.sunlight is not None) if f.msaa else f.gbuffer.fbo


def sun_color(look) -> np.ndarray:
    return np.array(srgb_to_linear(look.sun.color)) * look.sun.intensity


class SkyPass(Pass):
    name = "sky"
    reads = ("look.sun", "view")
    writes = ("scene_target",)

    def run(self, r, f) -> None:
        if f.scene_cached:
            return
        target = scene_target(f)
        target.use()
        target.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)
        r.ctx.disable(moderngl.DEPTH_TEST)
        v, look = f.view, f.still
        set_uniforms(r.sky_prog, {
            "uFwd": v.fwd, "uRight": v.right, "uUp": v.up, "uSunDir": look.sun.direction(),
            "uSunColor": sun_color(look), "uFlatSky": look.scene == "calibration",
            "uFlatSkyColor": np.array(srgb_to_linear(CALIBRATION_SKY))})
        r.programs.draw(r.sky_prog, moderngl.TRIANGLES)
