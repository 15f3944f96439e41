"""The fog pass (Biri 4.1, 4.2): per texel of the fog target (1/fog_scale of the frame),
the fog's raw transmittance from the eye to the visible point, and the inverse distance
used (passes/fog.frag). `bind_fog` sets a fog plan's uniforms on any program that
includes fog/transmittance.glsl (this pass, and the rays of the transmittance API)."""

from __future__ import annotations

import math

import moderngl
import numpy as np

from fogbank.kinds import KINDS
from fogbank.kinds.packing import loop_tables
from fogbank.model.fields import MAX_PARTICLES
from fogbank.render.gl import TEX, set_uniforms
from fogbank.render.passes.base import Pass
from fogbank.render.passes.fog_filter import filter_fog, jittered


def bind_fog(r, prog, plan) -> None:
    """Upload a fog plan: the packed layers, the particle rows, the noise tile and the
    global fog uniforms."""
    if "uLayer" in prog:   # constant indexing lets the compiler trim the array
        u = prog["uLayer"]
        u.write(plan.packed.data[:u.array_length].tobytes())
    if "uGroupCounts" in prog:   # the loops over layers of one kind (packing.layer_code)
        slots, counts = loop_tables(plan.key, prog.extra.get("inline_particles", True))
        for name, values in (("uLayerSlots", slots), ("uGroupCounts", counts)):
            u = prog[name]
            u.write(values[:4 * u.array_length].tobytes())
    if plan.has_particles:
        r.particles.write(plan.packed.particles.tobytes(), viewport=(0, 0, MAX_PARTICLES, 1))
        light = np.zeros((MAX_PARTICLES, 4), np.float32)
        light[:, 0] = 1.0 if plan.particle_light is None else plan.particle_light
        light[:, 1] = plan.packed.radii
        r.particles.write(light.tobytes(), viewport=(0, 1, MAX_PARTICLES, 1))
    r.particles.use(TEX["uParticles"])
    (r.noise.get(plan.noise) if plan.noise else r.noise.none()).use(TEX["uNoise"])
    set_uniforms(prog, plan.uniforms)


def held_key(f, plan, whole: bool) -> tuple:
    """What a still camera's held fog depends on: the scene pass it was drawn over, the fog
    scale, the time-invariant layers' plan, the effects it reads, and whether it is the
    whole fog (nothing moves: then also its light, passes/light.py) or the time-invariant
    sums under moving layers."""
    e = f.still.effects
    light = (e.lit, e.shafts, e.light_quality) if whole else None
    return (f.gbuffer.scene_key, e.fog_scale, plan.signature(), e.sun_through_fog, e.sky_distance, whole, light)


def whole_fog_held(f) -> bool:
    """Whether frame f's fog is a held whole fog already drawn (nothing moves and the
    camera stays): the frame draws no fog, and no light grid."""
    plan = f.fog_plan()
    if not plan.split or f.raymarch_steps or plan.split[1].key:
        return False
    h = f.gbuffer.held.get(f.still.effects.fog_scale)
    return h is not None and h.whole and h.key == held_key(f, plan.split[0], True)


class FogPass(Pass):
    """The whole fog per fog texel. For a stream whose camera stays still (the scene pass
    held; Renderer.begin(hold_fog) gives the plan its FogPlan.split) the part that does not
    change with time is held with the scene pass, built on the second frame that asks for
    the same one (so a look changed at every frame, a slider dragged, draws the whole fog
    once, as before):
    - where some layers move (wind, drift, particles), in two stages (passes/fog.frag
      FOG_STAGE): the time-invariant layers' sums are drawn once, and each frame draws only
      the moving layers over them, and their light;
    - where nothing moves, the frame's fog target itself, filtered, is held: later frames
      draw no fog at all (and no program is compiled for it)."""
    name = "fog"
    reads = ("gbuffer.invdist", "gbuffer.held", "fog_plan", "view", "light_grid")
    writes = ("fog", "gbuffer.held")

    def run(self, r, f) -> None:
        e = f.still.effects
        fbo, tex = f.targets.fog_target(e.fog_scale)
        plan = f.fog_plan()
        held = self._held(r, f, plan) if plan.split and not f.raymarch_steps else None
        if held is not None and held.whole:
            f.held_fog, f.fog_tex, f.filtered = held, held.texture, {"T"}
            return
        fbo.use()
        if held is None:
            prog = r.programs.fog(plan.key, f.raymarch_steps, e.sun_through_fog, f.light is not None)
            self._draw(r, f, prog, plan)
        else:
            moving = plan.split[1]
            prog = r.programs.fog(moving.key, None, e.sun_through_fog, f.light is not None, stage=2,
                                  held_direct=held.direct is not None)
            held.texture.use(TEX["uHeld"])
            if held.direct is not None:
                held.direct.use(TEX["uHeldDirect"])
            self._draw(r, f, prog, moving)
            f.held_fog = held
        f.fog_tex = tex

    def _held(self, r, f, plan):
        """The frame's held fog, drawn now if this is the second frame that asks for it;
        None: draw the whole fog (the first frame that asks)."""
        e, g = f.still.effects, f.gbuffer
        still, moving = plan.split
        whole = not moving.key
        key = held_key(f, still, whole)
        h = g.held.get(e.fog_scale)
        if h is not None and h.key == key:
            return h
        if g.fog_seen.get(e.fog_scale) != key:
            g.fog_seen[e.fog_scale] = key
            return None
        direct = not whole and any(KINDS[k].log_transmittance is not None for k in still.packed.kinds)
        r.caches.park()   # held_fog may release targets: never the bound framebuffer
        h = g.held_fog(r.ctx, e.fog_scale, direct, whole=whole)
        h.key = None
        if whole:   # the whole fog as a frame draws it, then its filter (or a copy) into the held target
            fbo, tex = f.targets.fog_target(e.fog_scale)
            fbo.use()
            prog = r.programs.fog(plan.key, None, e.sun_through_fog, f.light is not None)
            self._draw(r, f, prog, plan)
            if jittered(f.still):
                filter_fog(r, tex, h.fbo)
            else:
                r.ctx.copy_framebuffer(h.fbo, fbo)
        else:
            h.fbo.use()
            prog = r.programs.fog(still.key, None, e.sun_through_fog, False, stage=1, held_direct=direct)
            self._draw(r, f, prog, still)
        h.key = key
        return h

    @staticmethod
    def _draw(r, f, prog, plan) -> None:
        e = f.still.effects
        bind_fog(r, prog, plan)
        v = f.view
        # the angle one fog texel subtends (vertically), for filtering distant noise
        footprint = 2.0 * math.tan(math.radians(f.still.camera.fov) / 2.0) / f.still.height * e.fog_scale
        set_uniforms(prog, {"uFogScale": e.fog_scale, "uFwd": v.fwd, "uRight": v.right, "uUp": v.up,
                            "uSkyDistance": e.sky_distance, "uSunDir": f.still.sun.direction(),
                            "uNoiseFootprint": footprint})
        if f.light is not None and "uLightGrid" in prog.extra["declared"]:
            f.light.bind(prog)
        f.gbuffer.invdist.use(TEX["uInvDist"])
        r.programs.draw(prog, moderngl.TRIANGLES)
