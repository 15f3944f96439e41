"""What a frame needs from the CPU, prepared apart from the GL work: the view, and the
fog's plan (particle states simulated, layers packed relative to the eye in float64,
the fog uniforms). `prepare` makes no GL call, so the renderer runs it on its own thread
while the GL thread draws the shadow, sky and scene passes, which do not need it.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from concurrent.futures import Future
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from fogbank.kinds import KINDS
from fogbank.kinds.particle_light import particle_light
from fogbank.kinds.packing import Packed, direct_density, enabled, pack_layers, split_by_time, uses_noise, variant
from fogbank.scene import camera as cam

SIM_CACHE = 64   # particle states kept (at most 16 layers x 1024 particles each)


class Simulations:
    """Simulated states (particles) by (layer, time, wind, scene), simulated once by the
    layer's kind and kept in a small LRU (rays at one time, frames of a paused look). Safe
    to use from two threads."""

    def __init__(self, size: int = SIM_CACHE):
        self.size = size
        self._cache: OrderedDict = OrderedDict()
        self._lock = threading.Lock()

    def state(self, layer, time: float, fog):
        key = (layer.model_dump_json(), float(time), tuple(fog.wind.vector()), fog.scene)
        with self._lock:
            if key in self._cache:
                self._cache.move_to_end(key)
                return self._cache[key]
        state = KINDS[layer.kind].simulate(layer, time, fog)
        with self._lock:
            self._cache[key] = state
            while len(self._cache) > self.size:
                self._cache.popitem(last=False)
        return state


@dataclass
class FogPlan:
    """The fog's uniforms for one draw: its layers packed relative to the reference point
    `ref` at `time`, which programs it needs, and the global fog uniforms."""
    key: tuple                     # the layers' variant (which fog program)
    packed: Packed
    has_particles: bool
    noise: tuple | None            # the baked noise tile it samples, if any
    uniforms: dict[str, Any]
    # with a still camera: the plans of the layers that do not change with time and of the
    # others (kinds/packing.py split_by_time), for the fog pass's two stages
    split: tuple["FogPlan", "FogPlan"] | None = None
    # each packed particle's share of the sunlight (kinds/particle_light.py), for lit looks
    particle_light: np.ndarray | None = None

    def signature(self) -> tuple:
        """Everything of this plan that the fog program reads: equal signatures draw equal fog."""
        return (self.key, self.packed.data.tobytes(), self.noise, tuple(sorted(self.uniforms.items())))

    def swarms(self):
        """(slot, values) of each layer drawn as quads (particles), in slot order."""
        return [(n, v) for n, (k, v) in enumerate(zip(self.packed.kinds, self.packed.values))
                if KINDS[k].quads]


def plan_fog(fog, time: float, ref, sims: Simulations, split: bool = False, light: bool = False,
             whole=None) -> FogPlan:
    """The fog's plan at `time`, its layers packed relative to `ref`; with `split`, also the
    plans of its layers that do not change with time and of the others (FogPlan.split);
    with `light` (a frame's, of a lit look), each particle's share of the sunlight, through
    the `whole` look's fog (a split half's particles are lit through every layer, not
    only their half's: the moving half's smoke was lit as if no static fog stood toward the sun).
    `whole`: (the whole look, its packed particles, their light, their radii): a half whose
    particle rows are the whole's takes their light as it is (computed once a frame)."""
    states = {i: sims.state(l, time, fog) for i, l in enabled(fog) if KINDS[l.kind].simulate}
    e = fog.effects
    n = fog.noise
    packed = pack_layers(fog, states, ref, time)
    lights = None
    if light and e.lit and states:
        if (whole is not None and np.array_equal(packed.particles, whole[1])
                and np.array_equal(packed.radii, whole[3])):
            lights = whole[2]
        else:
            lights = particle_light(fog if whole is None else whole[0], packed, ref, time,
                                    fog.sun.direction(), e.sky_distance)
    halves = tuple(plan_fog(part, time, ref, sims, light=light, whole=(fog, packed.particles, lights, packed.radii))
                   for part in split_by_time(fog)) if split else None
    return FogPlan(
        key=variant(fog),
        packed=packed,
        particle_light=lights,
        has_particles=bool(states),
        noise=(n.size, n.octaves, n.blur, n.seed) if uses_noise(fog) else None,
        uniforms={"uStartDistance": e.start_distance, "uCutoffDistance": e.cutoff_distance,
                  "uCutoffFog": e.cutoff_mode == "fog",
                  "uMaxOpacity": e.max_opacity, "uDensity": direct_density(fog)},
        split=halves,
    )


@dataclass
class Frame:
    """One frame on its way through the passes: the inputs, and what each pass leaves
    for the next (declared in render/passes)."""
    still: Any                     # StillParams
    slot: str                      # whose scene pass is cached (a session, or stills)
    msaa: bool
    view: cam.View
    targets: Any                   # render/targets.py Targets
    gbuffer: Any                   # render/targets.py GBuffer
    plan: Future                   # FogPlan, prepared off the GL thread
    scene_key: tuple = ()
    scene_cached: bool = False
    draft: bool = False            # a preview (a user drags): cheaper light (passes/light.py)
    coarse_shadow: bool = False    # lit by the preview shadow map (Renderer.begin)
    warp: Any = None               # the scene pass warped from an earlier preview's (render/reproject.py Warp)
    out_warp: Any = None           # the finished frame warped from an earlier preview's (Warp; passes/warp_out.frag)
    look_key: str | None = None    # a preview's look but for heading, pitch, time and size (reproject.look_key)
    shadow: Any = None             # the shadow map it is lit by (render/resources.py ShadowMap; the shadow pass)
    light: Any = None              # the light grid its fog is lit by (passes/light.py LightGrid), if any
    held_fog: Any = None           # the held fog this frame's fog was drawn over (render/targets.py HeldFog)
    # the fog target's channels already filtered ("T": a held whole fog's, passes/fog.py)
    filtered: set = field(default_factory=set)
    raymarch_steps: int | None = None
    sun_view_proj: np.ndarray | None = None
    fog_tex: Any = None
    channels: int = 3              # the image's: 3 RGB, 4 RGBX (passes/output.py)
    image: np.ndarray | None = None

    def fog_plan(self) -> FogPlan:
        return self.plan.result()
