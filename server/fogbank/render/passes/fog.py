"""The fog pass (Biri 4.1, 4.2): per texel of the fog target (1/fog_scale of the frame),
the fog's raw transmittance from the eye to the visible point, and the inverse distance
used (passes/fog.frag). `bind_fog` sets a fog plan's uniforms on any program that
includes fog/transmittance.glsl (this pass, and the rays of the transmittance API)."""

from __future__ import annotations

import math

import moderngl

from fogbank.kinds.packing import loop_tables
from fogbank.render.gl import TEX, set_uniforms
from fogbank.render.passes.base import Pass


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


class FogPass(Pass):
    name = "fog"
    reads = ("gbuffer.invdist", "fog_plan", "view", "shadow_map")
    writes = ("fog",)

    def run(self, r, f) -> None:
        e = f.still.effects
        fbo, tex = f.targets.fog_target(e.fog_scale)
        fbo.use()
        plan = f.fog_plan()
        shafts = e.shafts > 0
        prog = r.programs.fog(plan.key, f.raymarch_steps, e.sun_through_fog, shafts)
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
                                "uShaftLength": min(e.sky_distance, 2.0 * half)})
            r.shadow.nearest.use(TEX["uShadow"])
        f.gbuffer.invdist.use(TEX["uInvDist"])
        r.programs.draw(prog, moderngl.TRIANGLES)
        if shafts:   # the unit's own filtering again, for the scene pass's PCF
            r.shadow.nearest.clear(TEX["uShadow"])
        f.fog_tex = tex
