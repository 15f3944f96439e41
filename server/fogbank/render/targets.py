"""Render targets: the scratch targets of one frame size, and the cached scene pass
(G-buffer) of one slot and size, each in a byte-budgeted LRU (render/cache.py)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import ClassVar

import moderngl
import numpy as np

from fogbank.render.cache import ByteLRU
from fogbank.render.gl import release_fbo

MSAA_SAMPLES = 4
TILE_LIST_WIDTH = 256   # texels a row of GBuffer.tile_list
SILHOUETTE_TILE = 4   # px: the composite redoes pixels with two surfaces by tiles of this size
# bytes per pixel of each GPU allocation (for the caches' byte budgets and the cost model)
OUT_BPP = 4                                   # RGBA8 output renderbuffer
# the output's readback (host memory, Targets.readback): as GL gives it (bottom row first)
# and top row first, 3 bytes a pixel each (a still's RGB; a stream frame's RGBX takes 4)
READBACK_BPP = 2 * 3
MSAA_BPP = MSAA_SAMPLES * (8 + 4 + 4)         # RGBA16F + R32F + depth24/stencil8, per sample
LINEAR_BPP = 2 * 8 * 4 // 3                   # two RGBA16F blur targets and their mip pyramids
# near surface: RGBA16F colour, R32F inverse distance, depth; far surface (two-surface
# resolve, passes/resolve.frag): RGBA16F colour and coverage, R32F inverse distance
GBUFFER_BPP = 8 + 4 + 4 + 8 + 4
SUNLIGHT_BPP = 8                              # RGBA16F direct sunlight (sun_through_fog only), per sample
FOG_BPP = 16                                  # RGBA32F (raw T, 1/distance, T toward the sun, in-scattered light J)
# the light grid (render/passes/light.py), per column and slice: the march's (S, A) halves
# in RGBA32UI outputs (4 slices a texel), their RG16F stack, its buffer and 3D texture
LIGHT_BPS = 4 + 4 + 4 + 4
# a still camera's held light (render/passes/light.py), per froxel: RGBA32F
HELD_LIGHT_BPS = 16
# a still camera's held fog (passes/fog.py), per fog texel: RGBA32F sums (tau, 1/distance,
# tau toward the sun, 0), and R32F tauDirect (looks with a time-invariant direct layer)
HELD_FOG_BPP = 16
HELD_DIRECT_BPP = 4
# the held composite's inputs (passes/composite_inputs.frag), per pixel: A and B packed as
# halves and the sky's bits in an RGBA32UI, W in an RGBA16F;
# and, over a coarser fog, the depth24 that marks where it needs the depth-aware weights
# (passes/held_edges.frag)
HELD_INPUTS_BPP = 16 + 8
HELD_EDGES_BPP = 4
# the held composite's two-surface pixels (HeldFog.far_pixels): per SILHOUETTE_TILE tile an
# RG32I (its first pixel's place in the list, a mask of its pixels listed), and per listed
# pixel its RG32I coordinates and its composite, by its dtype (RGBA8 for the output,
# RGBA16F before the separate blur)
HELD_FAR_TILE_BYTES = 8
HELD_FAR_LIST_BPP = 8
HELD_FAR_OUT_BPP = {"f1": 4, "f2": 8}
FAR_LIST_WIDTH = 256   # texels a row of HeldFog.far_list
# the set bits of each 16-bit mask (a 4x4 tile's listed pixels): a lookup, 0.1 ms at
# 1280x720 against 1.2 for summing the tiles' bools
_BIT_COUNTS = np.unpackbits(np.arange(1 << 16, dtype="<u2").view(np.uint8)).reshape(-1, 16).sum(axis=1, dtype=np.uint8)


def fog_texture(ctx: moderngl.Context, size: tuple[int, int]) -> moderngl.Texture:
    """An RGBA32F fog target. Its readers fetch texels, but for the held composite's
    bilinear blend (passes/composite_held.glsl heldFogTSmooth), which filters it LINEAR,
    clamped to its edge as fogQuad's texels are."""
    tex = ctx.texture(size, 4, dtype="f4")
    tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
    tex.repeat_x = tex.repeat_y = False
    return tex


@dataclass
class Targets:
    """Scratch render targets for one frame size, shared by every caller (one frame is
    drawn at a time by a worker). The MSAA, fog and blur targets are made on first use."""
    ctx: moderngl.Context
    size: tuple[int, int]
    out: moderngl.Framebuffer
    msaa_fbos: dict[bool, moderngl.Framebuffer] = field(default_factory=dict)   # by sunlight
    fog: dict[tuple[int, int], tuple[moderngl.Framebuffer, moderngl.Texture]] = field(default_factory=dict)
    linear: list[tuple[moderngl.Framebuffer, moderngl.Texture]] = field(default_factory=list)
    light: dict[tuple[int, int], "LightTargets"] = field(default_factory=dict)   # by (tile, slices)
    out_depth: moderngl.Framebuffer | None = None   # out's colour and a depth buffer (with_depth)
    # by channels (3 RGB, 4 RGBX): the kept readback buffers (readback)
    _readback: dict[int, tuple[bytearray, np.ndarray]] = field(default_factory=dict, repr=False, compare=False)

    def readback(self, channels: int = 3) -> tuple[bytearray, np.ndarray]:
        """The output's readback buffers, made on first use and kept with the targets:
        (the bytes as GL reads them, bottom row first; the (height, width, channels) image,
        top row first). A frame reads into memory that is already mapped: with the worker's
        fixed mmap threshold (workers/worker.py) every fresh 2.7 MB buffer of a 1280x720
        frame was a new mapping whose pages faulted in as they were written, twice a frame
        (the read, and the copy that made the flipped image contiguous for the JPEG
        encoder): 1.7 ms of its 3.6 ms encode."""
        if channels not in self._readback:
            w, h = self.size
            self._readback[channels] = (bytearray(w * h * channels), np.empty((h, w, channels), np.uint8))
        return self._readback[channels]

    def with_depth(self) -> moderngl.Framebuffer:
        """The output's colour with a depth buffer of its own (a preview's warped frame
        masks its composite by depth: passes/warp_out.frag), made on first use."""
        if self.out_depth is None:
            self.out_depth = self.ctx.framebuffer(color_attachments=self.out.color_attachments,
                                                  depth_attachment=self.ctx.depth_renderbuffer(self.size))
        return self.out_depth

    def read_image(self, channels: int = 3) -> np.ndarray:
        """The output target as (height, width, channels) uint8, top row first, in the kept
        image (overwritten by the next read of this size and channels). 4: RGBX (alpha 255),
        for the JPEG encoder, which reads it as fast as RGB: mesa reads the RGBA8 target's
        4 bytes a pixel as they are, and packs 3 pixel by pixel (1280x720: 0.18 against 0.93
        ms, and the flip 0.15 against 0.16)."""
        w, h = self.size
        raw, image = self.readback(channels)
        self.out.read_into(raw, components=channels, alignment=1)
        np.copyto(image, np.frombuffer(raw, np.uint8).reshape(h, w, channels)[::-1])
        return image

    def nbytes(self) -> int:
        w, h = self.size
        n = w * h * OUT_BPP
        if self.out_depth is not None:
            n += w * h * 4   # its depth buffer
        n += sum(len(raw) + image.nbytes for raw, image in self._readback.values())
        for sun in self.msaa_fbos:
            n += w * h * (MSAA_BPP + (MSAA_SAMPLES * SUNLIGHT_BPP if sun else 0))
        for scale, _ in self.fog:
            n += -(-w // scale) * -(-h // scale) * FOG_BPP
        n += len(self.linear) * w * h * 8 * 4 // 3   # with their mip pyramids (passes/blur.py)
        n += sum(t.nbytes() for t in self.light.values())
        return n

    def release(self) -> None:
        if self.out_depth is not None:   # its colour is out's, released with out
            depth = self.out_depth.depth_attachment
            self.out_depth.release()
            depth.release()
            self.out_depth = None
        for fbo in [self.out, *self.msaa_fbos.values()] + [f for f, _ in self.fog.values()] + \
                [f for f, _ in self.linear]:
            release_fbo(fbo)
        for t in self.light.values():
            t.release()
        self.light.clear()
        self.fog.clear()
        self.linear.clear()
        self.msaa_fbos.clear()
        self._readback.clear()

    def msaa(self, sunlight: bool = False) -> moderngl.Framebuffer:
        """Colour (RGBA16F), inverse distance (R32F), with `sunlight` the direct sunlight
        (RGBA16F), and depth, MSAA_SAMPLES per pixel; the colours are multisample textures,
        read sample by sample by the resolve pass. The sunlight attachment costs every
        frame (about 50 ms of 300 at 1280x720 on llvmpipe), so only looks that dim the
        sunlight by the fog have it."""
        if sunlight not in self.msaa_fbos:
            ctx, size = self.ctx, self.size
            colors = [ctx.texture(size, 4, samples=MSAA_SAMPLES, dtype="f2"),
                      ctx.texture(size, 1, samples=MSAA_SAMPLES, dtype="f4")]
            if sunlight:
                colors.append(ctx.texture(size, 4, samples=MSAA_SAMPLES, dtype="f2"))
            self.msaa_fbos[sunlight] = ctx.framebuffer(
                color_attachments=colors, depth_attachment=ctx.depth_renderbuffer(size, samples=MSAA_SAMPLES))
        return self.msaa_fbos[sunlight]

    def fog_target(self, scale: int, index: int = 0):
        """(framebuffer, texture) of (raw T, 1/distance, T toward the sun, lit share of the
        view ray) at 1/scale of the frame; index 1 is the filter pass's output."""
        if (scale, index) not in self.fog:
            w, h = self.size
            tex = fog_texture(self.ctx, (-(-w // scale), -(-h // scale)))
            self.fog[scale, index] = (self.ctx.framebuffer(color_attachments=[tex]), tex)
        return self.fog[scale, index]

    def light_grid(self, tile: int, slices: int) -> "LightTargets":
        """The light grid's targets for columns `tile` px apart and `slices` slices."""
        if (tile, slices) not in self.light:
            w, h = self.size
            self.light[tile, slices] = LightTargets.make(self.ctx, (-(-w // tile), -(-h // tile)), slices)
        return self.light[tile, slices]

    def linear_pair(self):
        """Two RGBA16F targets for the separate blur passes (mipmapped by the blur pass)."""
        while len(self.linear) < 2:
            tex = self.ctx.texture(self.size, 4, dtype="f2")
            tex.repeat_x = tex.repeat_y = False
            self.linear.append((self.ctx.framebuffer(color_attachments=[tex]), tex))
        return self.linear


@dataclass
class LightTargets:
    """The light grid (render/passes/light.py) of `columns` view rays cut into `slices`:
    the march's outputs, four slices a texel (RGBA32UI, passes/light.frag), the slices one
    above the other (RG16F, passes/light_atlas.frag), read into a buffer and written to
    `grid`, the 3D texture of (S, A) that fog/light_grid.glsl filters."""
    columns: tuple[int, int]
    slices: int
    march: moderngl.Framebuffer
    stack: moderngl.Framebuffer
    buffer: moderngl.Buffer
    grid: moderngl.Texture3D

    @staticmethod
    def make(ctx: moderngl.Context, columns: tuple[int, int], slices: int) -> "LightTargets":
        outs = [ctx.texture(columns, 4, dtype="u4") for _ in range(slices // 4)]
        for t in outs:
            t.filter = (moderngl.NEAREST, moderngl.NEAREST)
        stack = ctx.texture((columns[0], columns[1] * slices), 2, dtype="f2")
        grid = ctx.texture3d((*columns, slices), 2, dtype="f2")
        grid.filter = (moderngl.LINEAR, moderngl.LINEAR)
        grid.repeat_x = grid.repeat_y = grid.repeat_z = False
        return LightTargets(columns, slices, ctx.framebuffer(color_attachments=outs),
                            ctx.framebuffer(color_attachments=[stack]),
                            ctx.buffer(reserve=columns[0] * columns[1] * slices * 4), grid)

    def upload(self) -> None:
        """The stacked slices into the 3D texture, through the buffer (no trip to the host on
        a GPU)."""
        self.stack.read_into(self.buffer, components=2, dtype="f2", alignment=1)
        self.grid.write(self.buffer, alignment=1)

    def nbytes(self) -> int:
        return self.columns[0] * self.columns[1] * self.slices * LIGHT_BPS

    def release(self) -> None:
        release_fbo(self.march)
        release_fbo(self.stack)
        self.buffer.release()
        self.grid.release()


@dataclass
class HeldFog:
    """The time-invariant part of a still camera's fog at one fog scale (passes/fog.py,
    stage 1), kept with its scene pass: the sums; `key` is what drew them."""
    fbo: moderngl.Framebuffer           # stage 1's targets: the sums (+ tauDirect)
    sums: moderngl.Texture
    direct: moderngl.Texture | None
    whole: bool = False                 # `sums` holds the whole fog target, filtered (nothing moves)
    key: object = None
    # the held composite's inputs over this fog (passes/composite_inputs.frag): AB, W at
    # the frame's size, and what drew them; `edges`, a depth buffer at that size that marks
    # where W is not bilinear (passes/held_edges.frag), and the held fog's key it was drawn
    # for (W reads the scene pass and the fog's 1/distance, not the effects)
    inputs: moderngl.Framebuffer | None = None
    inputs_key: object = None
    edges: moderngl.Renderbuffer | None = None
    edges_key: object = None
    # its scene pass's pixels with two surfaces (far_pixels): their coordinates, listed
    # FAR_LIST_WIDTH a row; by tile, where its pixels are in that list; how many; and
    # their composite, by output dtype ("f1" or "f2"; HeldFog.far_target)
    far_list: moderngl.Texture | None = None
    far_tiles: moderngl.Texture | None = None
    far_count: int = -1
    far_out: dict = field(default_factory=dict)

    @property
    def texture(self) -> moderngl.Texture:
        """The sums stage 2 reads, or (whole) the held fog target."""
        return self.sums

    def composite_inputs(self, ctx: moderngl.Context, size: tuple[int, int]) -> moderngl.Framebuffer:
        if self.inputs is None:
            # AB (with the sky's haze) and W per pixel (passes/composite_inputs.frag)
            texs = [ctx.texture(size, 4, dtype="u4"), ctx.texture(size, 4, dtype="f2")]
            for t in texs:
                t.filter = (moderngl.NEAREST, moderngl.NEAREST)
            self.inputs = ctx.framebuffer(color_attachments=texs)
        return self.inputs

    def edge_marks(self, ctx: moderngl.Context) -> moderngl.Renderbuffer:
        """The depth buffer of edge marks, at the inputs' size (made after them)."""
        if self.edges is None:
            self.edges = ctx.depth_renderbuffer(self.inputs.size)
            self.edges_key = None
        return self.edges

    def far_pixels(self, ctx: moderngl.Context, marks: np.ndarray) -> int:
        """List its scene pass's pixels with two surfaces, `marks` (height, width), nonzero
        where the near coverage is below 1 (passes/far_mask.frag; drawn once per held
        fog): the held composite draws them packed into FAR_LIST_WIDTH-wide rows
        (passes/composite.frag COMPACT), every lane a pixel with two surfaces, then copies
        each to its place (passes/far_scatter.frag). Drawn where they lie, over the
        silhouette tiles, two of three of llvmpipe's lanes ran for pixels of one surface (at
        1280x720 of the default look, 8084 such pixels in 2362 tiles fill 3073 groups of 8
        lanes). Returns how many; the list's padding repeats its last pixel."""
        h, w = marks.shape
        t = SILHOUETTE_TILE
        assert t * t == 16   # a tile's pixels are the bits of a 16-bit mask
        rows_t, cols_t = -(-h // t), -(-w // t)
        padded = marks != 0
        if padded.shape != (rows_t * t, cols_t * t):   # partial tiles at the right and top
            padded = np.pad(padded, ((0, rows_t * t - h), (0, cols_t * t - w)))
        # (tile row, tile column, pixel in the tile row by row): listed in that order, so a
        # tile's pixels follow its first, and a pixel's place is the tile's first place plus
        # the tile's listed pixels before it (passes/far_scatter.frag)
        tiles = padded.reshape(rows_t, t, cols_t, t).transpose(0, 2, 1, 3).reshape(rows_t, cols_t, t * t)
        flat = np.flatnonzero(tiles)
        n = len(flat)
        tile, k = np.divmod(flat, t * t)
        ty, tx = np.divmod(tile, cols_t)
        xs, ys = tx * t + k % t, ty * t + k // t
        bits = np.packbits(tiles, axis=2, bitorder="little").view("<u2")[..., 0]
        counts = _BIT_COUNTS[bits].astype(np.int32)
        per_tile = np.empty((rows_t, cols_t, 2), np.int32)
        per_tile[..., 0] = np.cumsum(counts, dtype=np.int32).reshape(rows_t, cols_t) - counts
        per_tile[..., 1] = bits
        self.far_tiles = ctx.texture((cols_t, rows_t), 2, dtype="i4", data=per_tile)
        rows = max(1, -(-n // FAR_LIST_WIDTH))
        coords = np.zeros((rows * FAR_LIST_WIDTH, 2), np.int32)
        if n:
            coords[:n] = np.stack([xs, ys], axis=1)
            coords[n:] = coords[n - 1]
        self.far_list = ctx.texture((FAR_LIST_WIDTH, rows), 2, dtype="i4", data=coords)
        for tex in (self.far_tiles, self.far_list):
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.far_count = n
        return n

    def far_target(self, ctx: moderngl.Context, dtype: str) -> tuple[moderngl.Framebuffer, moderngl.Texture]:
        """The listed pixels' composite, in the output's format (`dtype` "f1": the sRGB
        output; "f2": the linear target before the separate blur)."""
        if dtype not in self.far_out:
            tex = ctx.texture(self.far_list.size, 4, dtype=dtype)
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            self.far_out[dtype] = (ctx.framebuffer(color_attachments=[tex]), tex)
        return self.far_out[dtype]

    def nbytes(self) -> int:
        n = self.sums.width * self.sums.height
        n *= HELD_FOG_BPP + (HELD_DIRECT_BPP if self.direct else 0)
        if self.far_tiles is not None:
            n += self.far_tiles.width * self.far_tiles.height * HELD_FAR_TILE_BYTES
            listed = self.far_list.width * self.far_list.height
            n += listed * (HELD_FAR_LIST_BPP + sum(HELD_FAR_OUT_BPP[d] for d in self.far_out))
        if self.inputs is not None:
            n += self.inputs.width * self.inputs.height * HELD_INPUTS_BPP
        if self.edges is not None:
            n += self.edges.width * self.edges.height * HELD_EDGES_BPP
        return n

    def release(self) -> None:
        release_fbo(self.fbo)
        release_fbo(self.inputs)
        if self.edges is not None:
            self.edges.release()
        for t in (self.far_tiles, self.far_list):
            if t is not None:
                t.release()
        for fbo, _ in self.far_out.values():
            release_fbo(fbo)
        self.inputs = self.edges = self.far_tiles = self.far_list = None
        self.far_out.clear()
        self.far_count = -1


@dataclass
class GBuffer:
    """A cached scene pass (colour, inverse distance and, for looks with sun_through_fog,
    the direct sunlight) for one slot (a streaming session, or stills) and size; redrawn
    only when scene, camera, sun or MSAA change. With MSAA it holds two surfaces per pixel
    (passes/resolve.frag): the near one in `color`, `invdist` and `sunlight`, the far one
    in the `far_*` textures, with the near one's coverage in far_color's alpha. A preview
    (no MSAA) draws straight into `fbo` and has one surface (`two_surfaces` False)."""
    fbo: moderngl.Framebuffer      # colour + inverse distance (+ sunlight) + single-sample depth
    resolve_fbo: moderngl.Framebuffer   # the resolve's outputs: near, far (and their sunlight)
    color: moderngl.Texture
    invdist: moderngl.Texture
    sunlight: moderngl.Texture | None
    far_color: moderngl.Texture
    far_invdist: moderngl.Texture
    far_sunlight: moderngl.Texture | None
    tiles_fbo: moderngl.Framebuffer     # R8, one texel per SILHOUETTE_TILE tile: 1 where a pixel has two surfaces
    scene_key: object = None
    mips_key: object = None        # the scene pass whose mip pyramid the textures hold
    two_surfaces: bool = False     # the far textures hold this scene pass's far surfaces
    tile_list: moderngl.Texture | None = None   # RG32I: runs of marked tiles (silhouette_tiles)
    tile_count: int = -1           # how many runs; -1: not listed since the tiles were drawn
    held: dict[int, HeldFog] = field(default_factory=dict)   # by fog scale
    # what the latest frame did with it (Renderer.begin): "new" (made for it), "redrawn"
    # (another scene pass drawn over it) or "reused" (its scene pass as it was)
    last_frame: str = "new"
    fog_seen: dict[int, object] = field(default_factory=dict)   # the held-fog key of the last frame, by fog scale
    # the light grid's time-invariant froxels (render/passes/light.py, LIGHT_STAGE 1), kept
    # with the scene pass: RGBA32F in the grid's atlas layout, what drew it, and the key of
    # the last frame that asked
    held_light: moderngl.Framebuffer | None = None
    held_light_key: object = None
    light_seen: object = None
    # a preview's scene pass drawn whole, which later previews that only turn the camera
    # warp (render/reproject.py): copies of colour, inverse distance (and sunlight), the
    # view it was drawn from, and what else it depends on (Renderer.begin warp_key)
    warp_base: moderngl.Framebuffer | None = None
    warp_view: object = None
    warp_key: object = None
    warp_serial: int = 0           # when it was kept (TargetCache.warp_source: the latest serves)
    # a preview's finished frame (RGBA8 as output), which the next previews of its look (at
    # any size) warp while the camera only turns (passes/warp_out.frag): the view and the
    # look's time it was drawn at, and the look (reproject.look_key)
    out_base: moderngl.Framebuffer | None = None
    out_view: object = None
    out_key: object = None
    out_time: float = 0.0
    out_serial: int = 0            # when it was kept (TargetCache.out_source)
    last_plan: tuple | None = None   # (what it was made of, its future): the last preview's fog plan (Renderer.begin)

    def keep_warp_base(self, ctx: moderngl.Context, view, key) -> None:
        """Copy the scene pass just drawn whole into the warp base (a preview's, one sample)."""
        if self.warp_base is None:
            def like(t: moderngl.Texture) -> moderngl.Texture:
                c = ctx.texture(t.size, t.components, dtype=t.dtype)
                c.repeat_x = c.repeat_y = False
                c.filter = (moderngl.NEAREST, moderngl.NEAREST) if t is self.invdist else (moderngl.LINEAR,) * 2
                return c
            self.warp_base = ctx.framebuffer(color_attachments=[like(t) for t in self.fbo.color_attachments])
        ctx.copy_framebuffer(self.warp_base, self.fbo)
        self.warp_view, self.warp_key = view, key
        GBuffer.kept += 1
        self.warp_serial = GBuffer.kept

    kept: ClassVar[int] = 0   # warp bases kept so far, in this process

    def keep_out_base(self, ctx: moderngl.Context, out: moderngl.Framebuffer, view, key, time: float) -> None:
        """Copy a preview's finished frame (`out`, this G-buffer's size) into the out base."""
        if self.out_base is None:
            tex = ctx.texture(out.size, 4)
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            self.out_base = ctx.framebuffer(color_attachments=[tex])
        ctx.copy_framebuffer(self.out_base, out)
        self.out_view, self.out_key, self.out_time = view, key, time
        GBuffer.kept += 1
        self.out_serial = GBuffer.kept

    def drop_warp_base(self) -> None:
        release_fbo(self.warp_base)
        release_fbo(self.out_base)
        self.warp_base = self.warp_view = self.warp_key = None
        self.out_base = self.out_view = self.out_key = None

    def held_fog(self, ctx: moderngl.Context, scale: int, direct: bool, whole: bool = False) -> HeldFog:
        """The held fog's targets at `scale` with a tauDirect target (`direct`), made anew
        when that differs from what it has; `whole`: its target holds the whole fog."""
        h = self.held.get(scale)
        if h is not None and (h.direct is not None) == direct:
            h.whole = whole
            return h
        if h is not None:
            h.release()
        size = (-(-self.color.width // scale), -(-self.color.height // scale))

        sums = fog_texture(ctx, size)   # the fog target itself where nothing moves (whole)
        tau_direct = ctx.texture(size, 1, dtype="f4") if direct else None
        if tau_direct is not None:
            tau_direct.filter = (moderngl.NEAREST, moderngl.NEAREST)
        fbo = ctx.framebuffer(color_attachments=[sums] + ([tau_direct] if direct else []))
        self.held[scale] = HeldFog(fbo, sums, tau_direct, whole)
        return self.held[scale]

    def mipmaps(self) -> None:
        """Build the colour's (and sunlight's) mip pyramid once per scene pass drawn."""
        if self.mips_key != self.scene_key:
            for tex in (self.color, self.sunlight):
                if tex is not None:
                    tex.build_mipmaps()
                    # bilinear within the nearest level: trilinear reads twice the texels
                    tex.filter = (moderngl.LINEAR_MIPMAP_NEAREST, moderngl.LINEAR)
            self.mips_key = self.scene_key

    def nbytes(self) -> int:
        n = self.color.width * self.color.height * (GBUFFER_BPP + (2 * SUNLIGHT_BPP if self.sunlight else 0))
        if self.mips_key is not None:   # the colour's (and sunlight's) mip pyramid: a third more
            n += self.color.width * self.color.height * (8 + (SUNLIGHT_BPP if self.sunlight else 0)) // 3
        if self.tile_list is not None:
            n += self.tile_list.width * self.tile_list.height * 8
        if self.held_light is not None:
            n += self.held_light.width * self.held_light.height * HELD_LIGHT_BPS
        if self.warp_base is not None:   # colour RGBA16F, inverse distance R32F (sunlight RGBA16F)
            n += self.color.width * self.color.height * (8 + 4 + (SUNLIGHT_BPP if self.sunlight else 0))
        if self.out_base is not None:    # RGBA8
            n += self.color.width * self.color.height * 4
        return n + sum(h.nbytes() for h in self.held.values())

    @property
    def tiles(self) -> moderngl.Texture:
        return self.tiles_fbo.color_attachments[0]

    def silhouette_tiles(self, ctx: moderngl.Context) -> tuple[moderngl.Texture | None, int]:
        """The tiles that hold a pixel with two surfaces, as runs along the tile rows: (an
        RG32I texture of (first tile's index into `tiles`, row-major; tiles in the run),
        TILE_LIST_WIDTH runs a row; how many runs). Read back once per scene pass (a few
        kB). The composite's second draw makes one quad per run: llvmpipe pays each small
        quad's setup and binning, about 4 us, and a silhouette marks its tiles in rows
        (1045 marked tiles of the default view at 1280x720 make 231 runs)."""
        if self.tile_count < 0:
            marks = np.frombuffer(self.tiles.read(), np.uint8)
            marks = marks.reshape(self.tiles.height, self.tiles.width) >= 128   # read with alignment 1
            edges = np.diff(np.pad(marks.astype(np.int8), ((0, 0), (1, 1))), axis=1)
            r0, c0 = np.nonzero(edges == 1)     # a run's first tile (row by row, left to right)
            r1, c1 = np.nonzero(edges == -1)    # one past its last
            runs = np.stack([r0 * marks.shape[1] + c0, c1 - c0], axis=1).astype(np.int32)
            self.tile_count = len(runs)
            rows = max(1, -(-len(runs) // TILE_LIST_WIDTH))
            if self.tile_list is None or self.tile_list.height < rows:
                if self.tile_list is not None:
                    self.tile_list.release()
                self.tile_list = ctx.texture((TILE_LIST_WIDTH, rows), 2, dtype="i4")
                self.tile_list.filter = (moderngl.NEAREST, moderngl.NEAREST)
            if len(runs):
                data = np.zeros((rows * TILE_LIST_WIDTH, 2), np.int32)
                data[:len(runs)] = runs
                self.tile_list.write(data.tobytes(), viewport=(0, 0, TILE_LIST_WIDTH, rows))
        return self.tile_list, self.tile_count

    def drop_held(self) -> None:
        """Release the held fog and light (its scene pass is about to be drawn anew)."""
        for h in self.held.values():
            h.release()
        self.held.clear()
        self.fog_seen.clear()
        release_fbo(self.held_light)
        self.held_light = self.held_light_key = self.light_seen = None

    def light_target(self, ctx: moderngl.Context, size: tuple[int, int]) -> moderngl.Framebuffer:
        """The held light's target, (re)made at `size` (columns x slices, rows)."""
        if self.held_light is None or self.held_light.size != size:
            release_fbo(self.held_light)
            tex = ctx.texture(size, 4, dtype="f4")
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            self.held_light = ctx.framebuffer(color_attachments=[tex])
            self.held_light_key = None
        return self.held_light

    def release(self) -> None:
        self.drop_held()
        self.drop_warp_base()
        release_fbo(self.tiles_fbo)
        if self.tile_list is not None:
            self.tile_list.release()
        self.resolve_fbo.release()   # its attachments are the near textures (released with fbo) and the far ones
        for tex in (self.far_color, self.far_invdist, self.far_sunlight):
            if tex is not None:
                tex.release()
        release_fbo(self.fbo)   # colour, inverse distance (sunlight) and the depth renderbuffer


ACTIVE_S = 2.0   # a scene pass asked for within this many seconds belongs to a session still drawing


class TargetCache:
    """Scratch targets by size and scene passes by (slot, size) under one byte budget: the
    scratch targets to half of it, the scene passes to the rest. Every release happens
    with a never-released 1x1 framebuffer bound: releasing the bound framebuffer leaves
    GL_INVALID_OPERATION behind (moderngl)."""

    def __init__(self, ctx: moderngl.Context, budget: int, clock=time.monotonic):
        self.ctx = ctx
        self.budget = int(budget)
        self._targets = ByteLRU(budget // 2, clock)    # (w, h) -> Targets
        self._gbuffers = ByteLRU(budget, clock)        # (slot, w, h, sunlight) -> GBuffer
        self.park_fbo = ctx.framebuffer(color_attachments=[ctx.renderbuffer((1, 1), 4)])

    def park(self) -> None:
        self.park_fbo.use()

    def targets(self, w: int, h: int) -> Targets:
        return self._targets.get((w, h), lambda: Targets(
            self.ctx, (w, h), self.ctx.framebuffer(color_attachments=[self.ctx.renderbuffer((w, h), 4)])))

    def gbuffer(self, slot: str, w: int, h: int, sunlight: bool = False) -> GBuffer:
        def make() -> GBuffer:
            ctx = self.ctx

            def tex(components: int, dtype: str, nearest: bool = False) -> moderngl.Texture:
                t = ctx.texture((w, h), components, dtype=dtype)
                t.repeat_x = t.repeat_y = False
                if nearest:
                    t.filter = (moderngl.NEAREST, moderngl.NEAREST)
                return t
            color, invdist = tex(4, "f2"), tex(1, "f4", nearest=True)
            far_color, far_invdist = tex(4, "f2", nearest=True), tex(1, "f4", nearest=True)
            sun, far_sun = (tex(4, "f2"), tex(4, "f2", nearest=True)) if sunlight else (None, None)
            fbo = ctx.framebuffer(color_attachments=[color, invdist] + ([sun] if sun else []),
                                  depth_attachment=ctx.depth_renderbuffer((w, h)))
            resolve_fbo = ctx.framebuffer(color_attachments=[color, invdist, far_color, far_invdist] +
                                          ([sun, far_sun] if sun else []))
            tiles = ctx.texture((-(-w // SILHOUETTE_TILE), -(-h // SILHOUETTE_TILE)), 1)
            tiles.filter = (moderngl.NEAREST, moderngl.NEAREST)
            return GBuffer(fbo, resolve_fbo, color, invdist, sun, far_color, far_invdist, far_sun,
                           ctx.framebuffer(color_attachments=[tiles]))
        return self._gbuffers.get((slot, w, h, sunlight), make)

    def trim(self, keep_targets=(), keep_gbuffers=()) -> None:
        """The scratch targets to half the budget and the scene passes to what is left;
        then, where the kept entries (the frame just drawn) take the whole over the
        budget, other slots' scene passes go first, then other sizes' targets: a worker
        holds at most the budget or its current frame's own targets and scene pass,
        whichever is more (at 1920x1080 with sunlight through fog, about 300 MB; before,
        each half could add that frame's share on top of its own). Scene passes go in
        the order of `eviction_order`, after the scratch targets of sizes no frame drew in
        ACTIVE_S: after eight 640x360 streams had ended, two 1280x720 streams lost a scene
        pass every fourth frame to their 24 MB (12 frames a second together, 31-34 on a
        fresh worker)."""
        self.park()
        self._targets.trim(keep_targets)
        over = self.nbytes() - self.budget
        if over > 0:   # the scratch targets of sizes no frame drew in ACTIVE_S go before scene passes
            idle = [k for k in self._targets.keys() if self._targets.idle_for(k) > ACTIVE_S]
            self._targets.trim(keep_targets, budget=self._targets.nbytes() - over, order=idle)
        t = self._targets.nbytes()
        order = self.eviction_order(keep_gbuffers)
        self._gbuffers.trim(budget=max(0, self.budget - t), order=order)
        self._targets.trim(keep_targets, budget=max(0, self.budget - self._gbuffers.nbytes()))

    def eviction_order(self, drawn=()) -> list:
        """Which scene passes go first when they outgrow the budget, by what their latest
        frame did with them (GBuffer.last_frame): those no frame asked for in ACTIVE_S
        (least recently used first), the other sizes of the slots just drawn, those redrawn
        over an older pass (a camera that moves: keeping them saves nothing), those just
        made (newest first: a newcomer does not push out a session that reuses its own),
        and last those reused. The scene passes just drawn (`drawn`) go only where another
        session's are in use. Least-recently-used alone thrashes under sessions served in
        turn: with one scene pass too many, each frame evicted the one the next frame
        needed, and every frame redrew its scene pass (two streams at 1280x720 on one
        worker: 2.8 frames a second each, against 25 for one)."""
        lru = self._gbuffers
        drawn = [k for k in drawn if k in lru]
        slots = {k[0] for k in drawn}
        keys = lru.keys()   # least recently used first
        idle = [k for k in keys if k not in drawn and lru.idle_for(k) > ACTIVE_S]
        own = [k for k in keys if k not in drawn and k not in idle and k[0] in slots]
        others = [k for k in keys if k not in drawn and k not in idle and k not in own]
        if not others:
            return idle + own
        active = others + drawn

        def did(what: str) -> list:
            return [k for k in active if lru.peek(k).last_frame == what]
        return idle + own + did("redrawn") + did("new")[::-1] + did("reused")

    def nbytes(self) -> int:
        return self._targets.nbytes() + self._gbuffers.nbytes()

    def out_source(self, slot: str, size: tuple[int, int], sunlight: bool, key, time: float,
                   max_age: float) -> GBuffer | None:
        """The slot's scene pass whose out base was kept last with this look
        (render/reproject.py look_key), at most `max_age` s of the look's time from `time`,
        at `size` or larger (the drag's ladder changes the previews' size; a smaller frame
        blown up would stay coarse)."""
        best = None
        for k in self._gbuffers.keys():
            if k[0] == slot and k[3] == sunlight and k[1] >= size[0] and k[2] >= size[1]:
                g = self._gbuffers.peek(k)
                if (g.out_key == key and abs(time - g.out_time) <= max_age
                        and (best is None or g.out_serial > best.out_serial)):
                    best = g
        return best

    def warp_source(self, slot: str, size: tuple[int, int], sunlight: bool, key) -> GBuffer | None:
        """The slot's scene pass whose warp base was kept last with this key
        (render/reproject.py warp_key), at `size` or larger: a preview warps from it
        whatever its own size (the drag's ladder changes the previews' size,
        stream/session.py), but a smaller base blown up would stay coarse (its terrain's
        detail is chosen for its own size: scene.py lod_levels)."""
        best = None
        for k in self._gbuffers.keys():
            if k[0] == slot and k[3] == sunlight and k[1] >= size[0] and k[2] >= size[1]:
                g = self._gbuffers.peek(k)
                if g.warp_key == key and (best is None or g.warp_serial > best.warp_serial):
                    best = g
        return best

    def clear(self) -> None:
        self.park()
        self._targets.clear()
        self._gbuffers.clear()

    def drop_slot(self, slot: str) -> None:
        """A session ended: its scene passes go, and both halves are held to their
        budgets again. The frame just drawn may have held more (a 1920x1080 frame's
        targets and scene pass, ~300 MB); with its session gone nothing keeps it."""
        self.park()
        for key in [k for k in self._gbuffers.keys() if k[0] == slot]:
            self._gbuffers.pop(key)
        self.trim()
