"""The jittered fog's filter (passes/fog_filter.frag): for looks whose fog pass samples
with a per-pixel jitter (volume noise, light shafts), a 3x3 depth-aware mean of the fog
target into a second one, which the particle quads and the composite then use. Looks
with closed forms only skip it: their fog texels stay exact."""

from __future__ import annotations

import moderngl

from fogbank.render.gl import TEX, set_uniforms
from fogbank.render.passes.base import Pass
from fogbank.render.programs import FULLSCREEN


def jittered_t(look) -> bool:
    """Is T itself sampled with a per-pixel jitter (an enabled volume noise layer)?"""
    return any(l.enabled and l.kind == "noise" and l.mode == "volume" for l in look.layers)


def jittered(look) -> bool:
    """Does the fog pass sample with a per-pixel jitter for this look (light shafts, or an
    enabled volume noise layer)? The cost model asks the same."""
    return look.effects.shafts > 0 or jittered_t(look)


class FogFilterPass(Pass):
    name = "fog_filter"
    reads = ("fog", "look")
    writes = ("fog",)

    def run(self, r, f) -> None:
        if not jittered(f.still):
            return
        fbo, tex = f.targets.fog_target(f.still.effects.fog_scale, 1)
        fbo.use()   # the particle quads draw into the bound target
        f.fog_tex.use(TEX["uFog"])
        prog = r.programs.get(FULLSCREEN, "passes/fog_filter.frag")
        # only what was sampled is filtered: closed-form channels pass through exact
        set_uniforms(prog, {"uFilterT": jittered_t(f.still), "uFilterLit": f.still.effects.shafts > 0})
        r.programs.draw(prog, moderngl.TRIANGLES)
        f.fog_tex = tex
