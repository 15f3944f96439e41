"""The fog pass (Biri 4.1, 4.2): per texel of the fog target (1/fog_scale of the frame),
the fog's raw transmittance from the eye to the visible point, and the inverse distance
used (passes/fog.frag). `bind_fog` sets a fog plan's uniforms on any program that
includes fog/transmittance.glsl (this pass, and the rays of the transmittance API)."""

from __future__ import annotations

import math

import moderngl

from fogbank.kinds import KINDS
from fogbank.kinds.packing import loop_tables
from fogbank.render.gl import TEX, set_uniforms
from fogbank.render.passes.base import Pass
from fogbank.render.passes.fog_filter import filter_fog, jittered_t


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
        r.particles.write(plan.packed.particles.tobytes())
    r.particles.use(TEX["uParticles"])
    (r.noise.get(plan.noise) if plan.noise else r.noise.none()).use(TEX["uNoise"])
    set_uniforms(prog, plan.uniforms)


def held_key(f, plan, whole: bool) -> tuple:
    """What a still camera's held fog depends on: the scene pass it was drawn over, the fog
    scale, the time-invariant layers' plan, the effects it reads, and whether it is the
    whole fog (nothing moves) or the time-invariant sums under moving layers."""
    e = f.still.effects
    return (f.gbuffer.scene_key, e.fog_scale, plan.signature(), e.sun_through_fog, e.shafts > 0, e.sky_distance,
            whole)


class FogPass(Pass):
    """The whole fog per fog texel. For a stream whose camera stays still (the scene pass
    held; Renderer.begin(hold_fog) gives the plan its FogPlan.split) the part that does not
    change with time is held with the scene pass, built on the second frame that asks for
    the same one (so a look changed at every frame, a slider dragged, draws the whole fog
    once, as before):
    - where some layers move (wind, drift, particles), in two stages (passes/fog.frag
      FOG_STAGE): the time-invariant layers' sums and the shafts' lit share (filtered as
      passes/fog_filter.py does) are drawn once, and each frame draws only the moving
      layers over them;
    - where nothing moves, the frame's fog target itself, filtered, is held: later frames
      draw no fog at all (and no program is compiled for it)."""
    name = "fog"
    reads = ("gbuffer.invdist", "gbuffer.held", "fog_plan", "view", "shadow_map")
    writes = ("fog", "gbuffer.held")

    def run(self, r, f) -> None:
        e = f.still.effects
        fbo, tex = f.targets.fog_target(e.fog_scale)
        plan = f.fog_plan()
        held = self._held(r, f, plan) if plan.split and not f.raymarch_steps else None
        if held is not None and held.whole:
            f.held_fog, f.fog_tex, f.filtered = held, held.texture, {"T", "lit"}
            return
        fbo.use()
        if held is None:
            prog = r.programs.fog(plan.key, f.raymarch_steps, e.sun_through_fog, e.shafts > 0)
            self._draw(r, f, prog, plan, shafts=e.shafts > 0)
        else:
            moving = plan.split[1]
            prog = r.programs.fog(moving.key, None, e.sun_through_fog, e.shafts > 0, stage=2,
                                  held_direct=held.direct is not None)
            held.texture.use(TEX["uHeld"])
            if held.direct is not None:
                held.direct.use(TEX["uHeldDirect"])
            self._draw(r, f, prog, moving, shafts=False)
            f.held_fog = held
            f.filtered = {"lit"}
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
        shafts = e.shafts > 0
        r.caches.park()   # held_fog may release targets: never the bound framebuffer
        h = g.held_fog(r.ctx, e.fog_scale, direct, filtered=shafts and not whole, whole=whole)
        h.key = None
        if whole:   # the whole fog as a frame draws it, then its filter (or a copy) into the held target
            fbo, tex = f.targets.fog_target(e.fog_scale)
            fbo.use()
            prog = r.programs.fog(plan.key, None, e.sun_through_fog, shafts)
            self._draw(r, f, prog, plan, shafts=shafts)
            filter_fog(r, tex, h.fbo, filter_t=jittered_t(f.still), filter_lit=shafts)
        else:
            h.fbo.use()
            prog = r.programs.fog(still.key, None, e.sun_through_fog, shafts, stage=1, held_direct=direct)
            self._draw(r, f, prog, still, shafts=shafts)
            if shafts:   # the lit share, filtered once (passes/fog_filter.py: only it was sampled)
                filter_fog(r, h.sums, h.filtered[0], filter_t=False, filter_lit=True)
        h.key = key
        return h

    @staticmethod
    def _draw(r, f, prog, plan, shafts: bool) -> None:
        e = f.still.effects
        bind_fog(r, prog, plan)
        v = f.view
        # the angle one fog texel subtends (vertically), for filtering distant noise
        footprint = 2.0 * math.tan(math.radians(f.still.camera.fov) / 2.0) / f.still.height * e.fog_scale
        set_uniforms(prog, {"uFogScale": e.fog_scale, "uFwd": v.fwd, "uRight": v.right, "uUp": v.up,
                            "uSkyDistance": e.sky_distance, "uSunDir": f.still.sun.direction(),
                            "uNoiseFootprint": footprint})
        if shafts:
            _, half = r.meshes.get(f.still.scene).bounds
            # the shadow map spans the scene's bounds (2 half); beyond, nothing is shadowed
            set_uniforms(prog, {"uSunViewProj": f.sun_view_proj, "uEye": v.eye,
                                "uShaftLength": min(e.sky_distance, 2.0 * half),
                                "uShadowBiasScale": f.shadow.bias_scale})
            f.shadow.nearest.use(TEX["uShadow"])
        f.gbuffer.invdist.use(TEX["uInvDist"])
        r.programs.draw(prog, moderngl.TRIANGLES)
        if shafts:   # the unit's own filtering again, for the scene pass's PCF
            f.shadow.nearest.clear(TEX["uShadow"])
