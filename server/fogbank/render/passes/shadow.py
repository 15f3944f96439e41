"""The sun's shadow map: depth of every mesh seen from the sun (orthographic), redrawn
only when the scene or the sun changes. A cached scene pass needs no shadow map, but
light shafts sample it in the fog pass, so then it is made current all the same (one map
serves every slot of the worker)."""

from __future__ import annotations

import moderngl

from fogbank.render.gl import set_uniform
from fogbank.render.passes.base import Pass
from fogbank.scene import camera as cam


class ShadowPass(Pass):
    name = "shadow"
    reads = ("look.sun", "meshes")
    writes = ("shadow_map",)

    def run(self, r, f) -> None:
        look = f.still
        vaos, bounds, _ = r.meshes.get(look.scene)
        center, half = bounds
        f.sun_view_proj = cam.ortho_sun(look.sun.direction(), center, half)
        if f.scene_cached and look.effects.shafts <= 0:
            return
        key = (look.scene, look.sun.azimuth, look.sun.elevation)
        if key == r.shadow.key:
            return
        r.shadow.fbo.use()
        r.shadow.fbo.clear(depth=1.0)
        r.ctx.enable(moderngl.DEPTH_TEST)
        r.ctx.disable(moderngl.CULL_FACE)
        set_uniform(r.shadow_prog, "uSunViewProj", f.sun_view_proj)
        for _, shadow_vao in vaos:
            shadow_vao.render(moderngl.TRIANGLES)
        r.shadow.key = key
