"""The scene pass: terrain (nearest chunks first) and objects, lit by the sun with the
shadow map, into the scene target (the MSAA target, resolved by the resolve pass, or for
a preview the slot's G-buffer). Cached per slot while scene, camera, sun and MSAA stay."""

from __future__ import annotations

import moderngl
import numpy as np

from fogbank.render.gl import TEX, set_uniforms
from fogbank.render.passes.base import Pass
from fogbank.render.passes.sky import scene_target, sun_color
from fogbank.render.resources import SHADOW_SIZE


class ScenePass(Pass):
    name = "scene"
    reads = ("meshes", "shadow_map", "view", "scene_target")
    writes = ("scene_target",)

    def run(self, r, f) -> None:
        if f.scene_cached:
            return
        look, view = f.still, f.view
        vaos, _, chunks = r.meshes.get(look.scene)
        target = scene_target(f)
        ctx = r.ctx
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE)
        set_uniforms(r.scene_prog, {
            "uViewProj": view.view_proj, "uSunViewProj": f.sun_view_proj, "uEye": view.eye,
            "uSunDir": look.sun.direction(), "uSunColor": sun_color(look),
            "uShadowTexel": 1.0 / SHADOW_SIZE})
        r.shadow.tex.use(TEX["uShadow"])
        for k, (scene_vao, _) in enumerate(vaos):
            if k == 0 and len(chunks):   # terrain: nearest chunks first
                order = np.argsort(np.linalg.norm(chunks[:, 2:5] - view.eye, axis=1))
                for first, count in chunks[order, :2].astype(int):
                    scene_vao.render(moderngl.TRIANGLES, vertices=int(count), first=int(first))
            else:
                scene_vao.render(moderngl.TRIANGLES)
        ctx.disable(moderngl.DEPTH_TEST)
        f.gbuffer.scene_key = f.scene_key
