"""The light grid: how much of the fog's in-scattered sunlight each view ray's fog gets,
slice by slice along the rays of a coarse grid of the frame (passes/light.frag, single
scattering: the fog toward the sun by the same closed forms, the scene's shadows from the
shadow map). The fog pass then lights each fog texel by the share at its own distance
(fog/light_grid.glsl), and the particle quads theirs.

Why a grid of rays and not samples per fog texel: the sunlit share changes slowly across
the image (shadow volumes are metres wide, and blur with distance), so one ray every
LIGHT_QUALITY tile of pixels, marched finely, costs a fraction of a fog pass (at 1280x720
and the "medium" grid, 80 x 45 rays of 16 slices: 58k points, against 230k texels of the
1/2-size fog); the rays' own points are fixed per column (no crawling noise), and the
share is interpolated in three dimensions (one filtered fetch of a 3D texture), so a
pixel's light follows its own distance across silhouettes. The transmittance stays
exact: the grid decides only how much of the fog's light is sunlit. Against a float64
integral of the calibration scene's shafts (tests/gl/test_light.py), 16 slices err about
as little as 32 (mean |dJ| 0.0039 against 0.0034), while the columns' spacing counts (8 px
0.0009, 24 px 0.0046): "medium" is 16 px and 16 slices.

A still camera holds its grid's time-invariant part, as the fog pass holds its fog: the
layers that do not change with time and the scene's shadows per froxel (LIGHT_STAGE 1,
drawn once), and each frame marches only the moving layers over them (LIGHT_STAGE 2);
where nothing moves the fog is held whole (passes/fog.py) and no grid is drawn.

Looks that light nothing (effects.lit off and no shafts) have no grid: their fog is lit
everywhere (the papers' model)."""

from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from fogbank.render.gl import TEX, set_uniforms
from fogbank.render.passes.base import Pass
from fogbank.render.programs import FULLSCREEN

# effects.light_quality -> (px between the grid's columns, slices a column, shadow-map
# samples a slice); a preview takes "low" (a user drags)
# "high" takes 8 shadow taps a slice: with 4, the trees' long shadows under a low sun
# (shaded-valley, 8 degrees) were undersampled, each column's jittered taps catching
# them differently, and the sunlit fog near the ground showed the columns as a blocky
# mottle (a fresh eye: 6-15 px cells). The light pass of that 1280x720 frame: 35 ms with
# 4 taps, 45 with 8, 63 with 16; a still camera's stream draws it once (LIGHT_STAGE 1).
LIGHT_QUALITY = {"low": (32, 12, 2), "medium": (16, 16, 2), "high": (8, 32, 8)}
# the slices' ends grow geometrically (fog/light_grid.glsl) with c = far / this: the first
# slice is about 2 m long for a far of 400 m and 32 slices
LIGHT_CURVE_M = 20.0


def lights(look) -> bool:
    """Does this look have a light grid (effects.lit, or shadows in the fog)?"""
    e = look.effects
    return e.lit or e.shafts > 0


def grid_shape(look, draft: bool = False) -> tuple[int, int, int]:
    """(tile px, slices, shadow taps) of the look's grid; a preview's is "low"."""
    return LIGHT_QUALITY["low" if draft else look.effects.light_quality]


@dataclass
class LightGrid:
    """A drawn grid: its 3D texture, and the uniforms that read it (fog/light_grid.glsl)."""
    texture: moderngl.Texture3D
    uniforms: dict

    def bind(self, prog) -> None:
        set_uniforms(prog, self.uniforms)
        self.texture.use(TEX["uLightGrid"])


def grid_uniforms(look, tile: int, slices: int, columns: tuple[int, int]) -> dict:
    far = look.effects.sky_distance
    return {"uLightFrame": np.array([look.width, look.height], dtype=float), "uLightTile": float(tile),
            "uLightColumns": np.array(columns, dtype=float), "uLightSlices": float(slices),
            "uLightFar": far, "uLightCurve": far / LIGHT_CURVE_M}


class LightPass(Pass):
    name = "light"
    reads = ("fog_plan", "view", "shadow_map", "look.sun", "gbuffer.held")
    writes = ("light_grid",)

    def run(self, r, f) -> None:
        from fogbank.render.passes.fog import whole_fog_held
        look = f.still
        if not lights(look) or f.raymarch_steps or whole_fog_held(f):
            return
        plan = f.fog_plan()
        f.light = draw_grid(r, f, plan, self._held(r, f, plan) if plan.split else None)

    @staticmethod
    def _held(r, f, plan):
        """A still camera's held light, drawn on the second frame that asks for the same
        (as the fog pass holds its fog): the time-invariant layers' sums and the scene's
        shadows per froxel (LIGHT_STAGE 1). None: draw the whole grid."""
        e, g = f.still.effects, f.gbuffer
        still, moving = plan.split
        if not moving.key:   # nothing moves: the fog pass holds the whole fog, lit by this grid
            return None
        key = (g.scene_key, still.signature(), grid_shape(f.still, f.draft), e.lit, e.shafts, e.sky_distance)
        if g.held_light_key == key:
            return g.held_light
        if g.light_seen != key:
            g.light_seen = key
            return None
        tile, slices, taps = grid_shape(f.still, f.draft)
        cols, rows = f.targets.light_grid(tile, slices).columns
        r.caches.park()   # light_target may release a target: never the bound framebuffer
        fbo = g.light_target(r.ctx, (cols * slices, rows))
        _march(r, f, still, stage=1, target=fbo)
        g.held_light_key = key
        return fbo


def _march(r, f, plan, stage: int, target) -> dict:
    """Draw passes/light.frag's LIGHT_STAGE `stage` for the fog of `plan` into `target`;
    returns the grid's uniforms."""
    from fogbank.render.passes.fog import bind_fog
    look, e, v = f.still, f.still.effects, f.view
    tile, slices, taps = grid_shape(look, f.draft)
    shadows = taps if e.shafts > 0 else 0
    t = f.targets.light_grid(tile, slices)
    uniforms = grid_uniforms(look, tile, slices, t.columns)
    prog = r.programs.light(plan.key, slices, shadows, e.lit, stage)
    bind_fog(r, prog, plan)
    set_uniforms(prog, {**uniforms, "uFwd": v.fwd, "uRight": v.right, "uUp": v.up, "uSunDir": look.sun.direction(),
                        "uSkyDistance": e.sky_distance, "uSlices": slices})
    if shadows and stage != 2:
        set_uniforms(prog, {"uSunViewProj": f.sun_view_proj, "uEye": v.eye, "uShafts": e.shafts,
                            "uShadowBiasScale": f.shadow.bias_scale})
        f.shadow.nearest.use(TEX["uShadow"])
    target.use()
    r.programs.draw(prog, moderngl.TRIANGLES)
    if shadows and stage != 2:   # the unit's own filtering again, for the scene pass's PCF
        f.shadow.nearest.clear(TEX["uShadow"])
    return uniforms


def draw_grid(r, f, plan, held=None) -> LightGrid:
    """The grid for frame f's view, lit through the fog of `plan` (a FogPlan): the march
    (passes/light.frag), then its slices stacked (passes/light_atlas.frag) and made a 3D
    texture. With
    `held` (a still camera's held froxels), only the moving layers are marched over it."""
    tile, slices, _ = grid_shape(f.still, f.draft)
    t = f.targets.light_grid(tile, slices)
    if held is None:
        uniforms = _march(r, f, plan, 0, t.march)
    else:
        held.color_attachments[0].use(TEX["uHeldLight"])
        uniforms = _march(r, f, plan.split[1], 2, t.march)
    atlas = r.programs.get(FULLSCREEN, "passes/light_atlas.frag")
    cols, rows = t.columns
    set_uniforms(atlas, {"uColumnsY": rows})
    t.stack.use()
    for a, tex in enumerate(t.march.color_attachments):
        t.stack.viewport = (0, 4 * a * rows, cols, 4 * rows)
        tex.use(TEX["uSlices4"])
        set_uniforms(atlas, {"uFirstSlice": 4 * a})
        r.programs.draw(atlas, moderngl.TRIANGLES)
    t.stack.viewport = (0, 0, cols, rows * slices)
    t.upload()
    return LightGrid(t.grid, uniforms)
