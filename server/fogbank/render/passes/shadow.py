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
        f.sun_view_proj = sun_view_proj(r, look)
        if f.scene_cached and look.effects.shafts <= 0:
            return
        f.shadow = shadow_map(r, look, f.coarse_shadow)


def sun_view_proj(r, look) -> np.ndarray:
    """World -> the sun's clip space: an orthographic view of the scene's bounding cube."""
    center, half = r.meshes.get(look.scene).bounds
    return cam.ortho_sun(look.sun.direction(), center, half)


def shadow_map(r, look, coarse: bool = False):
    """The shadow map of the look's scene and sun, drawn unless it is current: the full one
    (kept by sun), or with `coarse` the preview one (resources.ShadowMaps)."""
    mesh = r.meshes.get(look.scene)
    center, half = mesh.bounds
    key = sun_key(look)
    sm = r.shadows.draft if coarse else r.shadows.full(key)
    if key == sm.key:
        return sm
    view_proj = sun_view_proj(r, look)
    sm.fbo.use()
    sm.fbo.clear(depth=1.0)
    r.ctx.enable(moderngl.DEPTH_TEST)
    r.ctx.disable(moderngl.CULL_FACE)
    set_uniform(r.shadow_prog, "uSunViewProj", view_proj)
    casters, terrain = mesh.casters(coarse)
    for shadow_vao, count in casters:   # the terrain at the map's level of detail, and the objects
        shadow_vao.render(moderngl.TRIANGLES, vertices=count)
    # the lightmap's square: the shadow map's cube's, in x and z
    sm.lightmap_rect = np.array([center[0] - half, center[2] - half, 0.5 / half, 0.5 / half])
    if terrain is not None:
        r.ctx.disable(moderngl.DEPTH_TEST)   # a height field: one surface over each texel
        sm.lightmap_fbo.use()
        sm.lightmap_fbo.clear(1.0, 1.0, 1.0, 1.0)
        set_uniforms(r.lightmap_prog, {"uSunViewProj": view_proj, "uLightmapRect": sm.lightmap_rect,
                                       "uSunDir": look.sun.direction(), "uShadowTexel": 1.0 / sm.size,
                                       "uShadowBiasScale": sm.bias_scale})
        sm.tex.use(TEX["uShadow"])
        bake_vao, count = terrain
        bake_vao.render(moderngl.TRIANGLES, vertices=count)
        sm.lightmap.build_mipmaps()
        sm.lightmap.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
    sm.key = key
    if not coarse:
        r.shadows.drew(key)
    return sm
