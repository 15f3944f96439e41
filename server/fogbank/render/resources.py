"""GPU resources that outlive a frame: the scene meshes, the shadow map, the particle
texture and the baked noise tiles (caches of their own, apart from the passes)."""

from __future__ import annotations

import moderngl
import numpy as np

from fogbank.kinds.noise_bake import bake
from fogbank.model.fields import MAX_PARTICLES
from fogbank.scene import meshes

SHADOW_SIZE = 2048
NOISE_TILES = 4   # baked tiles kept per worker


class Meshes:
    """Each scene's vertex arrays (scene and shadow programs) and chunk table, built once."""

    def __init__(self, ctx, scene_prog, shadow_prog):
        self.ctx, self.scene_prog, self.shadow_prog = ctx, scene_prog, shadow_prog
        self._meshes: dict[str, tuple] = {}

    def get(self, name: str):
        """(vaos [(scene vao, shadow vao)], bounds, terrain chunks) of a scene."""
        if name not in self._meshes:
            m = meshes.build(name)
            fmt = ("3f 3f 3f 1f", "aPos", "aNormal", "aColor", "aMaterial")
            vaos = []
            if len(m.terrain_indices):
                vbo = self.ctx.buffer(m.terrain_vertices.tobytes())
                ibo = self.ctx.buffer(m.terrain_indices.tobytes())
                vaos.append((self.ctx.vertex_array(self.scene_prog, [(vbo, *fmt)], ibo, 4),
                             self.ctx.vertex_array(self.shadow_prog, [(vbo, "3f 28x", "aPos")], ibo, 4)))
            vbo = self.ctx.buffer(m.objects.tobytes())
            vaos.append((self.ctx.vertex_array(self.scene_prog, [(vbo, *fmt)]),
                         self.ctx.vertex_array(self.shadow_prog, [(vbo, "3f 28x", "aPos")])))
            self._meshes[name] = (vaos, m.bounds, m.terrain_chunks)
        return self._meshes[name]


class ShadowMap:
    """The sun's depth map (bilinear PCF per tap) and the (scene, sun) it was drawn for."""

    def __init__(self, ctx):
        self.tex = ctx.depth_texture((SHADOW_SIZE, SHADOW_SIZE))
        self.tex.compare_func = "<="
        self.tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self.tex.repeat_x = self.tex.repeat_y = False
        self.fbo = ctx.framebuffer(depth_attachment=self.tex)
        # the shafts' samples compare one texel each (their jitter smooths the edges):
        # bilinear PCF costs four
        self.nearest = ctx.sampler(texture=self.tex, filter=(moderngl.NEAREST, moderngl.NEAREST),
                                   compare_func="<=", repeat_x=False, repeat_y=False)
        self.key: object = None


class NoiseTiles:
    """Baked noise tiles as 3D textures by (size, octaves, blur, seed), and a 1-texel
    stand-in for looks that sample no noise (baking a 128^3 tile takes seconds that a look
    without noise should not pay)."""

    def __init__(self, ctx):
        self.ctx = ctx
        self._tiles: dict[tuple, moderngl.Texture] = {}
        self._none: moderngl.Texture | None = None

    def none(self) -> moderngl.Texture:
        if self._none is None:
            self._none = self.ctx.texture3d((1, 1, 1), 1, np.zeros(1, np.float32).tobytes(), dtype="f4")
        return self._none

    def get(self, key: tuple) -> moderngl.Texture:
        if key not in self._tiles:
            data = bake(*key)
            n = key[0]
            # GL wants x fastest; the baked array is indexed [x, y, z]
            tex = self.ctx.texture3d((n, n, n), 1, np.ascontiguousarray(data.transpose(2, 1, 0)).tobytes(),
                                     dtype="f4")
            # the mip pyramid filters distant noise in frames (common/noise_texture.glsl);
            # texelFetch at level 0 keeps the exact trilinear nearer, and in the rays API
            tex.build_mipmaps()
            tex.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
            tex.repeat_x = tex.repeat_y = tex.repeat_z = True
            if len(self._tiles) >= NOISE_TILES:
                self._tiles.pop(next(iter(self._tiles))).release()
            self._tiles[key] = tex
        return self._tiles[key]

    def clear(self) -> None:
        for tex in self._tiles.values():
            tex.release()
        self._tiles.clear()


def particle_texture(ctx) -> moderngl.Texture:
    """(x, y, z, strength) per particle, one row, relative to the draw's reference point."""
    tex = ctx.texture((MAX_PARTICLES, 1), 4, dtype="f4")
    tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
    return tex
