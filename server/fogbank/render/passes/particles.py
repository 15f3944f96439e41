"""Fischer's particles as instanced quads: each particle's clarity multiplied into the
fog target (glBlendFunc(ZERO, SRC_COLOR)) over the screen bounds of its sphere of
influence, with the same particleOpacity() as the fog transmittance. The particle rows
were uploaded by the fog pass; each swarm's values come from the fog plan."""

from __future__ import annotations

import moderngl

from fogbank.render.gl import set_uniforms
from fogbank.render.passes.base import Pass


class ParticlesPass(Pass):
    name = "particles"
    reads = ("gbuffer.invdist", "fog_plan", "view", "fog")
    writes = ("fog",)

    def run(self, r, f) -> None:
        plan = f.fog_plan()
        swarms = plan.swarms()
        if not swarms:
            return
        e = f.still.effects
        prog = r.programs.get("passes/particles.vert", "passes/particles.frag")
        v = f.view
        set_uniforms(prog, {"uFogScale": e.fog_scale, "uEye": v.eye, "uFwd": v.fwd, "uRight": v.right, "uUp": v.up,
                            "uViewProj": v.view_proj, "uDensity": plan.uniforms["uDensity"],
                            "uSkyDistance": e.sky_distance,
                            "uStartDistance": e.start_distance,
                            "uCutoffDistance": e.cutoff_distance})
        r.ctx.enable(moderngl.BLEND)
        r.ctx.blend_func = moderngl.ZERO, moderngl.SRC_COLOR   # dst *= clarity
        try:
            for _, s in swarms:
                if s["count"] < 1:
                    continue
                set_uniforms(prog, {"uFirst": int(s["first"]), "uRadius": float(s["radius"]),
                                    "uAlpha": float(s["alpha"])})
                r.programs.draw(prog, moderngl.TRIANGLE_STRIP, vertices=4, instances=int(s["count"]))
        finally:
            r.ctx.disable(moderngl.BLEND)
