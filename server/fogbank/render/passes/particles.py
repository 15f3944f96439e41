"""Fischer's particles as instanced quads over the screen bounds of each one's sphere of
influence, with the same particleOpacity() as the fog transmittance, drawn with
dual-source blending (passes/particles.frag): each particle's clarity multiplied into the
fog target's T, and its light composited over the fog's in-scattered sunlight, farthest
first. The particle rows were uploaded by the fog pass; each swarm's values come from
the fog plan. A lit look's particles are lit by the light grid (passes/light.py), the
sunlight that reaches each (kinds/particle_light.py) and, with shafts, the scene's
shadow map."""

from __future__ import annotations

import moderngl

from fogbank.render.gl import TEX, set_uniforms
from fogbank.render.passes.base import Pass

# glBlendFunc's second source (ARB_blend_func_extended, core in GL 3.3)
GL_SRC1_COLOR = 0x88F9


class ParticlesPass(Pass):
    name = "particles"
    reads = ("gbuffer.invdist", "fog_plan", "view", "fog", "light_grid", "shadow_map")
    writes = ("fog",)

    def run(self, r, f) -> None:
        plan = f.fog_plan()
        swarms = plan.swarms()
        if not swarms:
            return
        e = f.still.effects
        light = f.light is not None
        shadow = light and e.shafts > 0
        prog = r.programs.get("passes/particles.vert", "passes/particles.frag", LIGHT=int(light),
                              SHADOW=int(shadow))
        v = f.view
        set_uniforms(prog, {"uFogScale": e.fog_scale, "uEye": v.eye, "uFwd": v.fwd, "uRight": v.right, "uUp": v.up,
                            "uViewProj": v.view_proj, "uDensity": plan.uniforms["uDensity"],
                            "uSkyDistance": e.sky_distance,
                            "uStartDistance": e.start_distance,
                            "uCutoffDistance": e.cutoff_distance})
        if light:
            f.light.bind(prog)
        if shadow:
            set_uniforms(prog, {"uSunViewProj": f.sun_view_proj, "uShafts": e.shafts,
                                "uShadowBiasScale": f.shadow.bias_scale})
            f.shadow.nearest.use(TEX["uShadow"])
        r.ctx.enable(moderngl.BLEND)
        r.ctx.blend_func = moderngl.ONE, GL_SRC1_COLOR   # dst = src0 + dst src1
        try:
            for _, s in swarms:
                if s["count"] < 1:
                    continue
                set_uniforms(prog, {"uFirst": int(s["first"]), "uAlpha": float(s["alpha"])})
                r.programs.draw(prog, moderngl.TRIANGLE_STRIP, vertices=4, instances=int(s["count"]))
        finally:
            r.ctx.blend_func = moderngl.DEFAULT_BLENDING
            r.ctx.disable(moderngl.BLEND)
            if shadow:   # the unit's own filtering again, for the scene pass's PCF
                f.shadow.nearest.clear(TEX["uShadow"])
