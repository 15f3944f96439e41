"""The scene pass: terrain (the chunks in view, nearest first) and objects, lit by the
sun with the shadow map, into the scene target, cleared here (the sky pass then fills what
no surface covers): the MSAA target, resolved by the resolve pass, or for
a preview the slot's G-buffer. Cached per slot while scene, camera, sun and MSAA stay."""

from __future__ import annotations

import moderngl
import numpy as np

from fogbank.render.gl import TEX, set_uniforms
from fogbank.render.passes.base import Pass
from fogbank.render.passes.sky import scene_target, sun_color
from fogbank.render.resources import SHADOW_SIZE
from fogbank.scene import camera as cam
from fogbank.scene import meshes, terrain


# A terrain chunk is drawn coarser (meshes.LOD_STRIDES) where even its coarser cells would
# be at most this many pixels across on screen, at its nearest point: the far terrain's
# grid cells, a few pixels each, cost vertex and triangle work for no detail.
LOD_CELL_PX = 12.0


def lod_levels(nearest: np.ndarray, fov: float, height: int) -> np.ndarray:
    """Each chunk's level of detail (index into LOD_STRIDES) from the distance (m) of its
    nearest point: the coarsest whose cells span at most LOD_CELL_PX pixels there."""
    cell = 2.0 * terrain.EXTENT / (meshes.TERRAIN_CELLS - 1)                 # m
    px_per_m = height / (2.0 * np.tan(np.radians(fov) / 2.0) * np.maximum(nearest, 1e-3))
    level = np.zeros(len(nearest), dtype=int)
    for k, stride in enumerate(meshes.LOD_STRIDES[1:], start=1):
        level[cell * stride * px_per_m <= LOD_CELL_PX] = k
    return level


class ScenePass(Pass):
    name = "scene"
    reads = ("meshes", "shadow_map", "lightmap", "view")
    writes = ("scene_target",)

    def run(self, r, f) -> None:
        if f.scene_cached:
            return
        look, view = f.still, f.view
        mesh = r.meshes.get(look.scene)
        target = scene_target(f)
        target.use()
        target.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)
        ctx = r.ctx
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE)
        common = {"uViewProj": view.view_proj, "uSunViewProj": f.sun_view_proj, "uEye": view.eye,
                  "uSunDir": look.sun.direction(), "uSunColor": sun_color(look), "uShadowTexel": 1.0 / SHADOW_SIZE}
        r.shadow.tex.use(TEX["uShadow"])
        if mesh.terrain is not None:
            # the terrain first (it hides most of the rest): its chunks in view, nearest first,
            # then the far land
            set_uniforms(r.terrain_prog, {**common, "uLightmapRect": r.shadow.lightmap_rect})
            r.shadow.lightmap.use(TEX["uLightmap"])
            chunks = mesh.chunks
            seen = chunks[cam.spheres_in_view(view.view_proj, chunks[:, 2:5], chunks[:, 5])]
            dist = np.linalg.norm(seen[:, 2:5] - view.eye, axis=1)
            level = lod_levels(dist - seen[:, 5], look.camera.fov, look.height)
            for k in np.argsort(dist):
                first, count = seen[k, [0, 1]] if level[k] == 0 else seen[k, [4 + 2 * level[k], 5 + 2 * level[k]]]
                mesh.terrain.render(moderngl.TRIANGLES, vertices=int(count), first=int(first))
            first, count = mesh.far
            if count:
                mesh.terrain.render(moderngl.TRIANGLES, vertices=int(count), first=int(first))
        set_uniforms(r.scene_prog, common)
        mesh.objects.render(moderngl.TRIANGLES)
        f.gbuffer.scene_key = f.scene_key
