"""The sky behind the scene: a fullscreen triangle on the far plane into the scene
target (MSAA or the G-buffer), with the sun's disc and glow (common/sky.glsl). Drawn
after the scene with the depth test, so it shades only the pixels (samples) that no
surface covers: drawn first, it shaded every pixel of the frame and the terrain then
painted over most of them (20 of 190 ms at 1280x720 on llvmpipe). A preview's scene
pass, drawn whole with its sky, is kept as the base that the next previews warp while
the camera only turns (render/reproject.py)."""

from __future__ import annotations

import moderngl
import numpy as np

from fogbank.model.fields import srgb_to_linear
from fogbank.render import reproject
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
    reads = ("look.sun", "view", "scene_target")
    writes = ("scene_target", "gbuffer.warp_base")

    def run(self, r, f) -> None:
        if f.scene_cached:
            return
        scene_target(f).use()
        ctx = r.ctx
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = "<="   # the far plane's 1.0 against the cleared 1.0
        v, look = f.view, f.still
        set_uniforms(r.sky_prog, {
            "uFwd": v.fwd, "uRight": v.right, "uUp": v.up, "uSunDir": look.sun.direction(),
            "uSunColor": sun_color(look), "uFlatSky": look.scene == "calibration",
            "uFlatSkyColor": np.array(srgb_to_linear(CALIBRATION_SKY))})
        warp = f.warp or f.out_warp
        r.programs.draw(r.sky_prog, moderngl.TRIANGLES)   # after a warp, its depths leave it the pixels drawn anew
        ctx.depth_func = "<"
        ctx.disable(moderngl.DEPTH_TEST)
        if warp is None and not f.msaa and f.draft:   # a preview's pass drawn whole: what the next ones warp
            f.gbuffer.keep_warp_base(ctx, v, reproject.warp_key(look, f.coarse_shadow))
