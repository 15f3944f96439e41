"""The sun's shadow map: depth of every mesh seen from the sun (orthographic), and the
terrain's lightmap baked from it (its sun visibility seen from above, passes/lightmap.frag),
both redrawn only when the scene or the sun changes. A cached scene pass needs no shadow
map, but light shafts sample it in the fog pass, so then it is made current all the same.
The worker keeps a few full maps by sun (resources.ShadowMaps), which serve every slot. A
preview (a user drags) whose sun no full map was drawn for takes the preview map instead
(Renderer.begin; resources.DRAFT_SHADOW_SIZE): coarser, and about a tenth of the full
map's cost, which a dragged sun pays every frame."""

from __future__ import annotations

import moderngl

import numpy as np

from fogbank.render.gl import TEX, set_uniform, set_uniforms
from fogbank.render.passes.base import Pass
from fogbank.scene import camera as cam


def sun_key(look) -> tuple:
    """What a shadow map is drawn for: the scene and the sun's direction."""
    return (look.scene, look.sun.azimuth, look.sun.elevation)


class ShadowPass(Pass):
    name = "shadow"
    reads = ("look.sun", "meshes")
    writes = ("shadow_map", "lightmap")   # the frame's map: the full or the preview one (f.shadow)

    def run(self, r, f) -> None:
        look = f.still
        mesh = r.meshes.get(look.scene)
        center, half = mesh.bounds
        f.sun_view_proj = cam.ortho_sun(look.sun.direction(), center, half)
        if f.scene_cached and look.effects.shafts <= 0:
            return
        key = sun_key(look)
        sm = f.shadow = r.shadows.draft if f.coarse_shadow else r.shadows.full(key)
        if key == sm.key:
            return
        sm.fbo.use()
        sm.fbo.clear(depth=1.0)
        r.ctx.enable(moderngl.DEPTH_TEST)
        r.ctx.disable(moderngl.CULL_FACE)
        set_uniform(r.shadow_prog, "uSunViewProj", f.sun_view_proj)
        casters, terrain = mesh.casters(f.coarse_shadow)
        for shadow_vao, count in casters:   # the terrain at the map's level of detail, and the objects
            shadow_vao.render(moderngl.TRIANGLES, vertices=count)
        # the lightmap's square: the shadow map's cube's, in x and z
        sm.lightmap_rect = np.array([center[0] - half, center[2] - half, 0.5 / half, 0.5 / half])
        if terrain is not None:
            r.ctx.disable(moderngl.DEPTH_TEST)   # a height field: one surface over each texel
            sm.lightmap_fbo.use()
            sm.lightmap_fbo.clear(1.0, 1.0, 1.0, 1.0)
            set_uniforms(r.lightmap_prog, {"uSunViewProj": f.sun_view_proj, "uLightmapRect": sm.lightmap_rect,
                                           "uSunDir": look.sun.direction(), "uShadowTexel": 1.0 / sm.size,
                                           "uShadowBiasScale": sm.bias_scale})
            sm.tex.use(TEX["uShadow"])
            bake_vao, count = terrain
            bake_vao.render(moderngl.TRIANGLES, vertices=count)
            sm.lightmap.build_mipmaps()
            sm.lightmap.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
        sm.key = key
        if not f.coarse_shadow:
            r.shadows.drew(key)
