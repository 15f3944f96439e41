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


def filter_fog(r, source, fbo, filter_t: bool, filter_lit: bool) -> None:
    """The filter of `source` (a fog target's layout) into `fbo`: only what was sampled
    with a jitter; closed-form channels pass through exact."""
    fbo.use()   # the particle quads draw into the bound target
    source.use(TEX["uFog"])
    prog = r.programs.get(FULLSCREEN, "passes/fog_filter.frag")
    set_uniforms(prog, {"uFilterT": filter_t, "uFilterLit": filter_lit})
    r.programs.draw(prog, moderngl.TRIANGLES)


class FogFilterPass(Pass):
    name = "fog_filter"
    reads = ("fog", "look")
    writes = ("fog",)

    def run(self, r, f) -> None:
        # a held fog's channels were filtered when it was drawn (passes/fog.py)
        filter_t = jittered_t(f.still) and "T" not in f.filtered
        filter_lit = f.still.effects.shafts > 0 and "lit" not in f.filtered
        if not (filter_t or filter_lit):
            return
        fbo, tex = f.targets.fog_target(f.still.effects.fog_scale, 1)
        filter_fog(r, f.fog_tex, fbo, filter_t, filter_lit)
        f.fog_tex = tex
