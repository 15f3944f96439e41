"""What a look costs to render, estimated before rendering: seconds and GL memory.

The coefficients are seconds measured on the reference machine (2 CPU cores, Mesa
llvmpipe) at full fog resolution; `cost_scale` (a setting) scales them for faster
hardware. They are conservative fits of `fogbank`'s own renders (see
tests/gl/test_cost.py, which holds the estimate to within a factor of the measured time
for every kind): the point is to refuse a look that would hold a worker for minutes, and
to route cheap stills to the interactive worker, not to predict milliseconds.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from fogbank.kinds import KINDS
from fogbank.kinds.packing import changes_with_time, enabled, groups, uses_noise, variant
from fogbank.model.params import FogParams, StillParams
from fogbank.render.passes.fog_filter import jittered
from fogbank.render.passes.light import grid_shape, lights
from fogbank.render.targets import (FOG_BPP, GBUFFER_BPP, LIGHT_BPS, LINEAR_BPP, MSAA_BPP, MSAA_SAMPLES, OUT_BPP,
                                   READBACK_BPP, SUNLIGHT_BPP)

# seconds on the reference machine
# The scene pass (with the sky, and the resolve with MSAA), drawn over the countryside
# (the costliest scene) with the GL finished after each pass, the sun still (scripts/cost_fit.py):
# 7 ms at 160x90 and 240x135, 37 ms at 960x540, 47 ms at 1280x720 without MSAA; 16, 25,
# 126 and 180 ms with it. The fixed part was 0.10 s: a 240x135 preview was estimated at
# 15 times its scene pass and a 960x540 frame at 4 times, so a session calibrated on its
# previews (stream/session.py) took its larger frames for 2-3 times cheaper than they were.
SCENE_FIXED_S = 0.02          # shadow map check, terrain vertex work, programs
SCENE_S_PER_MPX = 0.28        # the scene pass with 4x MSAA, per megapixel
SCENE_PREVIEW_S_PER_MPX = 0.12
COMPOSITE_S_PER_MPX = 0.05
BLUR_S_PER_MPX = 0.25              # the fused blur: 25 mip taps with depth weights, and the pyramid
SUNLIGHT_S_PER_MPX = 0.08          # sun_through_fog's G-buffer attachment (~50 ms at 1280x720)
# the light grid (render/passes/light.py), per froxel: its own work (the march's
# bookkeeping, the scan's packing and the 3D texture) and each shadow-map sample; its layers
# cost what they cost per fog texel (once along the view ray, once more toward the sun
# when lit). At 1280x720, "medium" (58k froxels) of the default look: 6 ms unlit, 8-10 lit.
LIGHT_S_PER_FROXEL = 3e-8
SHADOW_TAP_S = 1.5e-8
SHADOW_MAP_S = 0.15   # a full shadow map and its lightmap, drawn for a sun no map was drawn for
JITTER_FILTER_S_PER_FOG_MPX = 0.035   # the 3x3 filter of a jittered fog target (~32 ms at 1280x720, fog_scale 1)
ENCODE_S_PER_MPX = {"jpg": 0.01, "png": 0.04, "webp": 0.08}
# the fog pass's cost per layer comes from each kind (kinds/<name>.py: seconds_per_mpx,
# extra_seconds), per megapixel of fog target
# llvmpipe compiles a fog program to machine code at its first draw, and that time grows
# faster than the program. Layers of one kind and variant are one loop in the program
# (kinds/packing.py layer_code), so the program grows with the distinct kinds, not the
# layers: 16 cosine layers of 8 terms took 43 s to compile inlined, 0.7 s as a loop.
# Fitted by hand (16x16 frames, first draw minus second): ~0.3 s for a few kinds, 1.8 s
# for 16 cosine terms inlined in one layer; charged only when the worker has not drawn
# that program yet.
JIT_S_PER_UNIT = 0.03
JIT_EXPONENT = 1.3
JIT_LOOP_UNITS = 1.0             # a loop's own code (its slot table reads)


@dataclass
class Cost:
    seconds: float
    memory: int                         # bytes of GL targets and images
    parts: dict[str, float] = field(default_factory=dict)   # seconds by contributor

    def biggest(self, n: int = 3) -> list[str]:
        return [k for k, v in sorted(self.parts.items(), key=lambda kv: -kv[1])[:n] if v > 0]


# A noise tile larger than the default 64^3 misses the caches more at every sample: at
# 960x540, 128 volume samples of a 128^3 tile took 1.4 times those of a 64^3 one (1.29 s
# against 0.93 s; scripts/cost_corners.py)
NOISE_TILE_FACTOR_PER_DOUBLING = 0.4
# toward the sun (effects.sun_through_fog) each layer is integrated again from every
# surface over sky_distance: 1.25 times its view ray's cost for 128 volume samples
SUN_LAYER_FACTOR = 1.3
# each froxel of the light grid marches its slice through every layer, and toward the sun
# from it when lit: per layer, about 4 fog texels' cost lit and 1.2 unlit (960x540, 128
# volume samples, "medium": +1.2 s lit and +0.34 s with shafts only, over 32.6k froxels)
LIGHT_LAYER_TEXELS = {True: 4.0, False: 1.2}


def noise_tile_factor(size: int) -> float:
    """How much more a noise sample costs with a `size`^3 tile than with the default 64^3."""
    import math
    return 1.0 + NOISE_TILE_FACTOR_PER_DOUBLING * max(0.0, math.log2(size / 64))


def _layer_seconds(layer, fog_mpx: float, tile: float = 1.0) -> float:
    """A layer's fog-pass seconds over `fog_mpx` megapixels; `tile`: the noise tile's
    factor (noise_tile_factor), for the kinds that sample it."""
    kind = KINDS[layer.kind]
    return kind.seconds_per_mpx * fog_mpx + kind.extra_seconds(layer, fog_mpx) * (tile if kind.uses_noise else 1.0)


def program_key(still: StillParams) -> tuple:
    """What a worker's compiled fog programs depend on: the layers' variant, whether it
    integrates toward the sun, and its light grid's shape (compile-time defines; the fog
    scale is a uniform)."""
    e = still.effects
    light = (e.lit, e.shafts > 0, grid_shape(still)) if lights(still) else None
    return variant(still), e.sun_through_fog, light


def jit_seconds(variant: tuple) -> float:
    """Estimated first-draw compile time of the fog program for a layers.variant() key:
    each distinct kind and variant's code once (packing.groups), a loop's own code for each
    that repeats."""
    units = sum(KINDS[name].jit_units(v) + (JIT_LOOP_UNITS if len(members) > 1 else 0.0)
                for (name, v), members in groups(variant))
    return JIT_S_PER_UNIT * units ** JIT_EXPONENT


def estimate(still: StillParams, msaa: bool = True, fmt: str = "jpg", scale: float = 1.0,
             compiled: bool = False, baked: bool = False, scene_cached: bool = False,
             fog_held: bool = False) -> Cost:
    """Seconds and memory to render and encode `still` (`scale` multiplies seconds); the
    fog program's first-draw compile is included unless `compiled`, the noise tile's bake
    unless `baked` (both once per worker: a stream's frame-to-frame estimates leave them
    out), and the scene pass unless `scene_cached` (a stream's worker keeps it while the
    camera, scene and sun stay: render/renderer.py Renderer.begin); with `fog_held` also
    the layers that do not change with time, the shafts and their filter (the worker
    holds them with the scene pass: render/passes/fog.py)."""
    px = still.width * still.height
    mpx = px / 1e6
    e = still.effects
    fog_mpx = mpx / (e.fog_scale ** 2)
    parts: dict[str, float] = {} if scene_cached else {
        "width*height (scene pass)": SCENE_FIXED_S + (SCENE_S_PER_MPX if msaa else SCENE_PREVIEW_S_PER_MPX) * mpx}
    parts["width*height (composite, encode)"] = (COMPOSITE_S_PER_MPX + ENCODE_S_PER_MPX.get(fmt, 0.08)) * mpx
    if e.blur != "off":
        parts["effects.blur"] = BLUR_S_PER_MPX * mpx
    drawn = [(i, layer) for i, layer in enumerate(still.layers)
             if layer.enabled and not (fog_held and not changes_with_time(layer, still))]
    noise_tile = noise_tile_factor(still.noise.size)
    for i, layer in drawn:
        parts[f"layers[{i}] ({KINDS[layer.kind].describe(layer)})"] = _layer_seconds(layer, fog_mpx, noise_tile)
    if e.sun_through_fog:   # every layer again, along the sun's direction, and the attachment
        parts["effects.sun_through_fog"] = SUNLIGHT_S_PER_MPX * mpx + SUN_LAYER_FACTOR * sum(
            _layer_seconds(layer, fog_mpx, noise_tile) for _, layer in drawn)
    if lights(still):
        tile, slices, taps = grid_shape(still)
        froxels = -(-still.width // tile) * -(-still.height // tile) * slices
        # a still camera's grid holds the layers that do not move and the shadows
        shadow = taps * SHADOW_TAP_S if e.shafts > 0 and not fog_held else 0.0
        parts["effects.lit, effects.shafts (the light grid)"] = froxels * (LIGHT_S_PER_FROXEL + shadow) + \
            froxels / 1e6 * LIGHT_LAYER_TEXELS[bool(e.lit)] * sum(
                _layer_seconds(layer, 1.0, noise_tile) for _, layer in drawn if not KINDS[layer.kind].quads)
    # a held fog of moving layers filters its volume noise each frame; with none, the held
    # fog is the filtered fog target itself
    filtered = jittered(still) and (bool(drawn) or not fog_held)
    if filtered:   # passes/fog_filter.py
        parts["the filter of jittered samples (volume noise)"] = JITTER_FILTER_S_PER_FOG_MPX * fog_mpx
    n = still.noise
    if not baked and uses_noise(still) and (n.size, n.octaves, n.blur, n.seed) != DEFAULT_BAKE:
        parts[f"noise.size = {n.size} (baking the noise tile, once per worker)"] = bake_seconds(n)
    if not compiled:
        key = variant(still)
        # toward the sun, the layers' code is inlined a second time
        parts[f"compiling the fog program for {len(key)} layers (once per worker)"] = \
            jit_seconds(key) * (2 if e.sun_through_fog else 1)
        if lights(still):   # the light grid's march: the layers again, toward the sun too when lit
            parts["compiling the light grid's program (once per worker)"] = jit_seconds(key) * (2 if e.lit else 1)
    # the output, its kept readback (render/targets.py Targets.readback) and the scene pass,
    # and 4 bytes a pixel of margin (the estimate's since it began)
    memory = px * (OUT_BPP + READBACK_BPP + GBUFFER_BPP + 4) + int(fog_mpx * 1e6) * FOG_BPP * (2 if filtered else 1)
    if msaa:
        memory += px * MSAA_BPP
    if e.sun_through_fog:   # the direct sunlight: near and far surface in the G-buffer, and the MSAA target
        memory += px * SUNLIGHT_BPP * (2 + (MSAA_SAMPLES if msaa else 0))
    if e.blur == "separate":
        memory += px * LINEAR_BPP
    if lights(still):
        tile, slices, _ = grid_shape(still)
        memory += -(-still.width // tile) * -(-still.height // tile) * slices * LIGHT_BPS
    if e.blur == "single":   # the mip pyramid of the colour (and sunlight): a third more
        memory += px * (8 + (SUNLIGHT_BPP if e.sun_through_fog else 0)) // 3
    seconds = sum(parts.values()) * scale
    return Cost(seconds, memory, {k: v * scale for k, v in parts.items()})


BAKE_S_PER_VOXEL_OCTAVE = 1.5e-7   # noise.bake on this machine: 1.1-1.6 s for 128^3, 6 octaves, blur 8
DEFAULT_BAKE = (64, 4, 2, 7)       # baked by every worker's warm-up draw


def bake_seconds(n) -> float:
    """Seconds to bake a noise tile (NoiseBake) that a worker has not baked yet."""
    return BAKE_S_PER_VOXEL_OCTAVE * n.size ** 3 * n.octaves


def plot_seconds(fog: FogParams, scale: float = 1.0) -> Cost:
    """A ray plot (model/ray_plot.py): each particle layer simulated once, a noise tile
    baked if a layer samples a tile no worker baked, and
    the float64 layers over ~4000 ground-march steps and 200 samples."""
    simulated = [l for _, l in enabled(fog) if KINDS[l.kind].simulate]
    parts = {"particle simulation": sum(KINDS[l.kind].simulate_seconds(l) for l in simulated),
             "layers": 0.002 * max(1, len(fog.layers))}
    n = fog.noise
    if uses_noise(fog) and (n.size, n.octaves, n.blur, n.seed) != DEFAULT_BAKE:
        parts["noise bake"] = bake_seconds(n)
    return Cost(sum(parts.values()) * scale, 0, {k: v * scale for k, v in parts.items()})


def transmittance_seconds(fog: FogParams, rays: int, distinct_times: int, scale: float = 1.0,
                          groups: int = 1, light: bool = False) -> Cost:
    """Rays cost little; each distinct time simulates every particle layer once; each
    group of rays sharing an origin and a time is one draw, its layers packed relative
    to that origin (measured on llvmpipe: ~40 us + ~28 us per layer + 0.15 us per particle).
    `light`: the light endpoint's rays, each marched in LIGHT_RAY_SLICES slices (toward the
    sun too when lit), and the look's shadow map drawn for its shadows."""
    from fogbank.render.rays import LIGHT_RAY_SLICES
    simulated = [l for _, l in enabled(fog) if KINDS[l.kind].simulate]
    sim = sum(KINDS[l.kind].simulate_seconds(l) for l in simulated)
    particles = sum(getattr(l, "count", 0) for l in simulated)
    per_ray = LIGHT_RAY_SLICES * (2 if fog.effects.lit else 1) if light else 1
    parts = {"rays": 2e-6 * rays * max(1, len(fog.layers)) * per_ray,
             "distinct ray times x particle simulation": distinct_times * sim,
             "distinct ray origins x packing": groups * (40e-6 + 28e-6 * len(fog.layers)
                                                         + 0.15e-6 * particles)}
    if light and fog.effects.shafts > 0:
        parts["the shadow map"] = SHADOW_MAP_S
    n = fog.noise
    if uses_noise(fog) and (n.size, n.octaves, n.blur, n.seed) != DEFAULT_BAKE:
        parts["noise bake"] = bake_seconds(n)
    return Cost(sum(parts.values()) * scale, rays * (80 if light else 48), {k: v * scale for k, v in parts.items()})
