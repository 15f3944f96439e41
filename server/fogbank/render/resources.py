"""GPU resources that outlive a frame: the scene meshes, the shadow map, the particle
texture and the baked noise tiles (caches of their own, apart from the passes)."""

from __future__ import annotations

import os
import threading
from collections import OrderedDict
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass

import moderngl
import numpy as np

from fogbank.kinds.noise_bake import bake
from fogbank.model.fields import MAX_PARTICLES
from fogbank.scene import meshes

SHADOW_SIZE = 2048
# A preview's shadow map (render/passes/shadow.py), drawn when the sun moves while a user
# drags: this many texels a side (0.92 m, against the full map's 0.23), from the terrain
# at this level of detail everywhere (meshes.LOD_STRIDES: 4 grid cells a side). Drawing
# the full map and baking its lightmap took 134-139 ms here whatever the frame's size,
# so every preview of a sun dragged took at least 150 ms; this one takes about 14.
DRAFT_SHADOW_SIZE = 512
DRAFT_SHADOW_LEVEL = 2
# Its depth bias, as a multiple of the full map's (scene/sun_visibility.glsl). Measured
# against the full map's lightmap averaged over 4x4 texels, with the sun 12 and 30 degrees
# high: the mean |difference| in sun visibility is 0.042 and 0.024 at 3; at 1 acne
# striped the ground (0.154, 0.059), at 4 light leaked (0.042, 0.028, lighter on average).
DRAFT_SHADOW_BIAS = 3.0
# Full maps a worker keeps, by scene and sun (about 21 MB each on llvmpipe). Sessions on
# one worker whose suns differ each need theirs: for the scene pass of an orbiting camera,
# and every frame for light shafts. With one map, two streams with shafts and different
# suns redrew it at every frame: 169 ms a frame at 960x540 against 17.
SHADOW_MAPS = 3
# A full map drawn for a sun among the last this many drawn is not work done once for a
# new sun (ShadowMaps.drew): more suns than SHADOW_MAPS in turn evict each other's maps, and
# the redraws are then what those looks cost a frame.
SUNS_SEEN = 4 * SHADOW_MAPS
NOISE_TILES = 4   # baked tiles kept per worker
# the background bake's nice value (Linux sets it per thread): it takes the cores the
# worker's raster threads leave. At the worker's own priority a 128^3 bake took a core from
# the other streams' frames for its seconds (a stream beside a look reseeded every 6 s kept
# 0.58-0.61 of its rate); the look that asked for the tile is the one that waits
BAKE_NICE = 19


@dataclass
class SceneMesh:
    """One scene's vertex arrays and tables. The terrain (detailed grid and far land) and
    the objects are drawn by programs of their own (passes/scene.frag TERRAIN)."""
    terrain: moderngl.VertexArray | None       # scene program, TERRAIN 1
    terrain_bake: moderngl.VertexArray | None  # the lightmap's program
    objects: moderngl.VertexArray              # scene program, TERRAIN 0
    shadow: list[tuple[moderngl.VertexArray, int]]   # the shadow program, every mesh: (vao, vertices; -1 all)
    bounds: tuple                              # centre and half-size (the shadow map's cube)
    chunks: np.ndarray                         # the terrain grid's chunks (scene/meshes.py)
    far: tuple[int, int]                       # first index and count of the far land
    full_detail: int = 0                       # terrain indices at full detail (shadow, lightmap)
    lod_error: np.ndarray | None = None        # each chunk's vertical error (m) at each level
    skirt0: np.ndarray | None = None           # each chunk's skirt at full detail: first index, count
    skirts: np.ndarray | None = None           # each level's skirt index count (the level's range ends with it)
    objects_full: int = -1                     # the objects' indices at full detail, from the first (-1: all)
    object_groups: np.ndarray | None = None    # the trees by chunk, full and coarse (meshes._objects)
    far_skirt: tuple[int, int] = (0, 0)        # the far land's inner skirt: first index, count
    # the preview shadow map's casters (the terrain at DRAFT_SHADOW_LEVEL, the objects) and
    # its lightmap's terrain (vao, vertices)
    draft_shadow: list[tuple[moderngl.VertexArray, int]] | None = None
    draft_bake: tuple[moderngl.VertexArray, int] | None = None
    far_blocks: np.ndarray | None = None       # the far land's blocks: first index, count, centre, radius

    def casters(self, draft: bool) -> tuple[list[tuple[moderngl.VertexArray, int]], tuple | None]:
        """What the full shadow map (or, `draft`, the preview one) is drawn from: its
        casters, and the terrain its lightmap bakes (None: a scene without terrain)."""
        if draft:
            return self.draft_shadow, self.draft_bake
        return self.shadow, (self.terrain_bake, self.full_detail) if self.terrain_bake is not None else None


class Meshes:
    """Each scene's vertex arrays, built once."""

    def __init__(self, ctx, terrain_prog, objects_prog, shadow_prog, bake_prog):
        self.ctx = ctx
        self.progs = terrain_prog, objects_prog, shadow_prog, bake_prog
        self._meshes: dict[str, SceneMesh] = {}

    def get(self, name: str) -> SceneMesh:
        if name not in self._meshes:
            terrain_prog, objects_prog, shadow_prog, bake_prog = self.progs
            m = meshes.build(name)
            fmt = ("3f 3f 3f 1f", "aPos", "aNormal", "aColor", "aMaterial")
            terrain = bake = None
            shadow, draft, draft_bake = [], [], None
            if len(m.terrain_indices):
                vbo = self.ctx.buffer(m.terrain_vertices.tobytes())
                ibo = self.ctx.buffer(m.terrain_indices.tobytes())
                # the terrain program reads no colour (its material: a skirt's, passes/scene.frag): skipped
                terrain = self.ctx.vertex_array(terrain_prog, [(vbo, *fmt)], ibo, 4, skip_errors=True)
                bake = self.ctx.vertex_array(bake_prog, [(vbo, "3f 3f 16x", "aPos", "aNormal")], ibo, 4)
                shadow.append((self.ctx.vertex_array(shadow_prog, [(vbo, "3f 28x", "aPos")], ibo, 4),
                               m.full_detail))
                coarse = meshes.terrain_at_level(m, DRAFT_SHADOW_LEVEL)
                cbo = self.ctx.buffer(coarse.tobytes())
                draft.append((self.ctx.vertex_array(shadow_prog, [(vbo, "3f 28x", "aPos")], cbo, 4), len(coarse)))
                draft_bake = (self.ctx.vertex_array(bake_prog, [(vbo, "3f 3f 16x", "aPos", "aNormal")], cbo, 4),
                              len(coarse))
            verts, idx = meshes.indexed(m.objects)
            vbo, ibo = self.ctx.buffer(verts.tobytes()), self.ctx.buffer(idx.tobytes())
            objects = self.ctx.vertex_array(objects_prog, [(vbo, *fmt)], ibo, 4)
            shadow.append((self.ctx.vertex_array(shadow_prog, [(vbo, "3f 28x", "aPos")], ibo, 4), m.objects_full))
            draft.append(shadow[-1])
            self._meshes[name] = SceneMesh(terrain, bake, objects, shadow, m.bounds, m.terrain_chunks,
                                           m.terrain_far, m.full_detail, m.terrain_lod_error,
                                           m.terrain_skirt0, m.terrain_skirts, m.objects_full, m.object_groups,
                                           m.terrain_far_skirt, draft, draft_bake, m.terrain_far_blocks)
        return self._meshes[name]


class ShadowMap:
    """The sun's depth map (bilinear PCF per tap) and the (scene, sun) it was drawn for;
    with it the terrain's lightmap: its sun visibility baked from above over the map's
    square (passes/lightmap.frag), mipmapped, and that square (x0, z0, 1/side). `size`
    texels a side for both (2048: 0.23 m), compared with `bias` times the full map's depth
    bias. What it is drawn from is the mesh's (SceneMesh.casters)."""

    def __init__(self, ctx, size: int = SHADOW_SIZE, bias: float = 1.0):
        self.size, self.bias_scale = size, bias
        self.lightmap = ctx.texture((size, size), 1, dtype="f1")
        self.lightmap.repeat_x = self.lightmap.repeat_y = False
        self.lightmap_fbo = ctx.framebuffer(color_attachments=[self.lightmap])
        self.lightmap_rect = np.array([0.0, 0.0, 1.0, 1.0])
        self.tex = ctx.depth_texture((size, size))
        self.tex.compare_func = "<="
        self.tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self.tex.repeat_x = self.tex.repeat_y = False
        self.fbo = ctx.framebuffer(depth_attachment=self.tex)
        # the shafts' samples compare one texel each (their jitter smooths the edges):
        # bilinear PCF costs four
        self.nearest = ctx.sampler(texture=self.tex, filter=(moderngl.NEAREST, moderngl.NEAREST),
                                   compare_func="<=", repeat_x=False, repeat_y=False)
        self.key: object = None

    def release(self) -> None:
        for obj in (self.nearest, self.fbo, self.tex, self.lightmap_fbo, self.lightmap):
            obj.release()


class ShadowMaps:
    """The worker's full shadow maps by the (scene, sun) each was drawn for, the least
    recently used let go past `keep` (SHADOW_MAPS), and the preview map (DRAFT_SHADOW_SIZE).
    `drawn` counts the full maps drawn, `new_suns` those drawn for a sun not among the last
    SUNS_SEEN drawn: a frame that drew one paid once for its sun (workers/worker.py)."""

    def __init__(self, ctx, keep: int = SHADOW_MAPS):
        self.ctx, self.keep = ctx, keep
        self._maps: OrderedDict[tuple, ShadowMap] = OrderedDict()
        self.draft = ShadowMap(ctx, DRAFT_SHADOW_SIZE, DRAFT_SHADOW_BIAS)
        self.drawn = self.new_suns = 0
        self._suns: OrderedDict[tuple, None] = OrderedDict()   # the suns drawn lately, newest last

    def get(self, key: tuple) -> ShadowMap | None:
        """The full map drawn for `key`, if kept."""
        sm = self._maps.get(key)
        return sm if sm is not None and sm.key == key else None

    def full(self, key: tuple) -> ShadowMap:
        """The full map for `key`: the one drawn for it, else a new one or the least
        recently used (its key cleared: the shadow pass draws it)."""
        if key in self._maps:
            self._maps.move_to_end(key)
            return self._maps[key]
        sm = self._maps.popitem(last=False)[1] if len(self._maps) >= self.keep else ShadowMap(self.ctx)
        sm.key = None
        self._maps[key] = sm
        return sm

    def drew(self, key: tuple) -> None:
        """A full map was drawn for `key` (the shadow pass)."""
        self.drawn += 1
        if key not in self._suns:
            self.new_suns += 1
        self._suns[key] = None
        self._suns.move_to_end(key)
        while len(self._suns) > SUNS_SEEN:
            self._suns.popitem(last=False)

    def clear(self) -> None:
        """Let every full map go (a worker over its memory budget: the next frame that needs
        one draws it again, 134-139 ms here), and forget the suns seen; the preview map
        stays."""
        for sm in self._maps.values():
            sm.release()
        self._maps.clear()
        self._suns.clear()


def _yield_cores() -> None:
    """Run this thread at BAKE_NICE (where the OS has per-thread priorities, as Linux does)."""
    try:
        os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), BAKE_NICE)
    except (AttributeError, OSError):   # no setpriority (Windows): it bakes at the worker's priority
        pass


class NoiseTiles:
    """Baked noise tiles as 3D textures by (size, octaves, blur, seed), and a 1-texel
    stand-in for looks that sample no noise (baking a 128^3 tile takes seconds that a look
    without noise should not pay)."""

    def __init__(self, ctx):
        self.ctx = ctx
        self._tiles: dict[tuple, moderngl.Texture] = {}
        self._none: moderngl.Texture | None = None
        self.baked = 0   # tiles baked (a frame that baked one paid for it)
        # tiles baked on a thread of their own while the worker draws other sessions'
        # frames (ready), oldest first; numpy lets the GIL go in the bake's big operations
        self._baking: OrderedDict[tuple, Future] = OrderedDict()
        self._pool: ThreadPoolExecutor | None = None

    def ready(self, key: tuple) -> bool:
        """Whether get(key) returns without baking: the tile is baked, or its bake on the
        background thread is done. Not ready: its bake is started there (once), and a
        stream's frame that needs it comes back later instead of holding the worker for
        the bake (0.3-1.5 s: every other stream on the worker waited; issue 33)."""
        if key in self._tiles:
            return True
        fut = self._baking.get(key)
        if fut is None:
            if self._pool is None:
                self._pool = ThreadPoolExecutor(1, thread_name_prefix="fogbank-bake", initializer=_yield_cores)
            while len(self._baking) >= NOISE_TILES:   # a tile asked for and never taken
                self._baking.popitem(last=False)[1].cancel()
            self._baking[key] = self._pool.submit(bake, *key)
            return False
        return fut.done()

    def none(self) -> moderngl.Texture:
        if self._none is None:
            self._none = self.ctx.texture3d((1, 1, 1), 1, np.zeros(1, np.float32).tobytes(), dtype="f4")
        return self._none

    def get(self, key: tuple) -> moderngl.Texture:
        if key not in self._tiles:
            fut = self._baking.pop(key, None)
            data = fut.result() if fut is not None and not fut.cancelled() else bake(*key)
            self.baked += 1
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
    """Two rows: (x, y, z, strength) per particle, relative to the draw's reference point;
    (its share of the sunlight, its radius in m, 0, 0) (kinds/particle_light.py: 1 for unlit
    looks; kinds/particles.py radii)."""
    tex = ctx.texture((MAX_PARTICLES, 2), 4, dtype="f4")
    tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
    return tex
