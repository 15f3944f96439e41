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
from fogbank.render.programs import FULLSCREEN
from fogbank.scene import camera as cam
from fogbank.scene import terrain


# A terrain chunk is drawn at the coarsest level of detail (meshes.LOD_STRIDES) whose
# vertical error (meshes.lod_errors) is at most this many pixels on screen at the chunk's
# nearest point (de Boer 2000, "Fast terrain rendering using geometrical mipmapping": the
# screen-space error). Only heights are coarser: a coarse triangle's points keep their
# exact x and z, so the ground's albedo and sun visibility (functions of x, z) are the
# same; silhouettes and distances move by about a pixel (a pixel on the view's axis: the
# distance is the eye's, not the depth, so toward the corners of a 55 degree view up to
# ~1.5 px). On llvmpipe a triangle of a few pixels costs its whole 4x4 block, so coarser
# far terrain is most of a frame's scene pass. Chunks at different levels meet with a
# step between their borders, which each chunk's skirt hides (meshes._skirt); an eye
# below the ground would see the skirts, and gets every chunk at full detail instead.
LOD_ERROR_PX = 1.0


def lod_levels(nearest: np.ndarray, error: np.ndarray, fov: float, height: int) -> np.ndarray:
    """Each chunk's level of detail (index into LOD_STRIDES) from the distance (m) of its
    nearest point and its vertical error (m) at each level, (chunks, levels): the coarsest
    whose error spans at most LOD_ERROR_PX pixels there."""
    px_per_m = height / (2.0 * np.tan(np.radians(fov) / 2.0) * np.maximum(nearest, 1e-3))
    level = np.zeros(len(nearest), dtype=int)
    for k in range(1, error.shape[1]):
        level[error[:, k] * px_per_m <= LOD_ERROR_PX] = k
    return level


def merged_ranges(first: np.ndarray, count: np.ndarray) -> list[tuple[int, int]]:
    """Index ranges (first, count), in order, with each range that starts where the one
    before it ends joined to it."""
    out: list[list[int]] = []
    for a, n in zip(first.astype(int), count.astype(int)):
        if out and out[-1][0] + out[-1][1] == a:
            out[-1][1] += n
        else:
            out.append([a, n])
    return [(a, n) for a, n in out]


class ScenePass(Pass):
    name = "scene"
    reads = ("meshes", "shadow_map", "lightmap", "view", "gbuffer.warp_base")
    writes = ("scene_target", "gbuffer.held")

    def run(self, r, f) -> None:
        if f.scene_cached:
            return
        if f.gbuffer.held:   # a fog held over the scene pass drawn before goes with it
            r.caches.park()   # never release the bound framebuffer's attachments
            f.gbuffer.drop_held()
        target = scene_target(f)
        target.use()
        if f.out_warp is not None:   # a warped finished frame: the scene only where its base did not see
            target.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)
            self._mask(r, f, f.out_warp, target)
            if f.out_warp.rects:
                self._draw(r, f, [cull for _, cull in f.out_warp.rects])
            f.gbuffer.scene_key = None   # a part of the pass: nothing later reuses it
            return
        if f.warp is None:
            target.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)
            self._draw(r, f, [f.view.view_proj])
        else:   # an earlier preview's pass along the new rays, then what it did not see
            self._warp(r, f)
            if f.warp.rects:   # one draw, culled to the rectangles: the warp's depths mask the rest
                self._draw(r, f, [cull for _, cull in f.warp.rects])
        f.gbuffer.scene_key = f.scene_key

    @staticmethod
    def _draw(r, f, culls: list[np.ndarray]) -> None:
        """The terrain and the objects that any of `culls` (view-projections) may see, into
        the bound scene target."""
        def in_view(centres, radii):
            return np.logical_or.reduce([cam.spheres_in_view(c, centres, radii) for c in culls])
        look, view = f.still, f.view
        mesh = r.meshes.get(look.scene)
        ctx = r.ctx
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE)
        common = {"uViewProj": view.view_proj, "uSunViewProj": f.sun_view_proj, "uEye": view.eye, "uFar": cam.FAR,
                  "uSunDir": look.sun.direction(), "uSunColor": sun_color(look),
                  "uShadowTexel": 1.0 / f.shadow.size, "uShadowBiasScale": f.shadow.bias_scale}
        f.shadow.tex.use(TEX["uShadow"])
        if mesh.terrain is not None:
            # the terrain first (it hides most of the rest): its chunks in view, nearest first,
            # then the far land
            set_uniforms(r.terrain_prog, {**common, "uLightmapRect": f.shadow.lightmap_rect})
            f.shadow.lightmap.use(TEX["uLightmap"])
            chunks = mesh.chunks
            keep = np.flatnonzero(in_view(chunks[:, 2:5], chunks[:, 5]))
            dist = np.linalg.norm(chunks[keep, 2:5] - view.eye, axis=1)
            if view.eye[1] < float(terrain.height(view.eye[0], view.eye[2])):
                # an eye below the ground sees the terrain's underside, and the skirts
                # hanging from it: every chunk at full detail, which needs none
                level = np.zeros(len(keep), dtype=int)
                skirts = False
            else:
                level = lod_levels(dist - chunks[keep, 5], mesh.lod_error[keep], look.camera.fov, look.height)
                skirts = True
            for k in np.argsort(dist):
                row, lv = chunks[keep[k]], level[k]
                if lv == 0:
                    mesh.terrain.render(moderngl.TRIANGLES, vertices=int(row[1]), first=int(row[0]))
                    if skirts:
                        first, count = mesh.skirt0[keep[k]]
                        mesh.terrain.render(moderngl.TRIANGLES, vertices=int(count), first=int(first))
                else:
                    mesh.terrain.render(moderngl.TRIANGLES, vertices=int(row[5 + 2 * lv]), first=int(row[4 + 2 * lv]))
            if mesh.far_blocks is not None and len(mesh.far_blocks):
                # the far land's blocks in view, consecutive ones as one draw
                blocks = mesh.far_blocks
                seen = in_view(blocks[:, 2:5], blocks[:, 5])
                for first, count in merged_ranges(blocks[seen, 0], blocks[seen, 1]):
                    mesh.terrain.render(moderngl.TRIANGLES, vertices=count, first=first)
            elif mesh.far[1]:
                mesh.terrain.render(moderngl.TRIANGLES, vertices=int(mesh.far[1]), first=int(mesh.far[0]))
            first, count = mesh.far_skirt
            if count and skirts:
                mesh.terrain.render(moderngl.TRIANGLES, vertices=int(count), first=int(first))
        set_uniforms(r.scene_prog, common)
        groups = mesh.object_groups
        if groups is None or not len(groups):
            mesh.objects.render(moderngl.TRIANGLES)
        else:
            # the water, the house and the bridge; then the trees by chunk in view, nearest
            # first, each group coarse where its coarse trees' largest gap to the full ones
            # is within LOD_ERROR_PX at its nearest point (scene/meshes.py TREE_SIDES)
            mesh.objects.render(moderngl.TRIANGLES, vertices=int(groups[0, 0]), first=0)
            keep = np.flatnonzero(in_view(groups[:, 2:5], groups[:, 5]))
            dist = np.linalg.norm(groups[keep, 2:5] - view.eye, axis=1)
            errors = np.stack([np.zeros(len(keep)), groups[keep, 8]], axis=1)
            level = lod_levels(dist - groups[keep, 5], errors, look.camera.fov, look.height)
            for k in np.argsort(dist):
                row = groups[keep[k]]
                first, count = (row[0], row[1]) if level[k] == 0 else (row[6], row[7])
                mesh.objects.render(moderngl.TRIANGLES, vertices=int(count), first=int(first))

    @staticmethod
    def _mask(r, f, warp, target) -> None:
        """The depth mask alone (passes/warp_mask.frag): 0 where the base saw the ray."""
        n = len(target.color_attachments)
        target.color_mask = [(False,) * 4] * n if n > 1 else (False,) * 4
        target.use()
        draw_warp(r, r.programs.get(FULLSCREEN, "passes/warp_mask.frag"), f.view, warp)
        target.color_mask = [(True,) * 4] * n if n > 1 else (True,) * 4
        target.use()

    @staticmethod
    def _warp(r, f) -> None:
        """Every pixel of the frame from the warp base along its new ray (passes/warp.frag),
        and its depth the mask of what is drawn anew: 0 where the base saw it, else 1."""
        prog = r.programs.get(FULLSCREEN, "passes/warp.frag", SUN_LIGHT=int(f.gbuffer.sunlight is not None))
        for name, tex in zip(("uBaseColor", "uBaseInvDist", "uBaseSunLight"), f.warp.source.color_attachments):
            tex.use(TEX[name])
        draw_warp(r, prog, f.view, f.warp)


def draw_warp(r, prog, view, warp) -> None:
    """Draw a program of passes/warp_seen.glsl (its textures bound) over the bound target,
    from `view` and the warp's base view, its depth written as the mask wherever it falls
    (the depth test on, passing always); the test is left on, passing where nearer, for
    the draws that the mask lets through."""
    b = warp.base
    set_uniforms(prog, {"uFwd": view.fwd, "uRight": view.right, "uUp": view.up,
                        "uBaseFwd": b.fwd, "uBaseRight": b.right, "uBaseUp": b.up})
    ctx = r.ctx
    ctx.enable(moderngl.DEPTH_TEST)
    ctx.depth_func = "1"   # always: every pixel's depth is the mask
    r.programs.draw(prog, moderngl.TRIANGLES)
    ctx.depth_func = "<"
