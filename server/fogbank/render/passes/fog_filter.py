"""The jittered fog's filter (passes/fog_filter.frag): for looks whose fog pass samples
T with a per-pixel jitter (volume noise), a 3x3 depth-aware mean of the fog target into a
second one, which the particle quads and the composite then use. Looks with closed forms
only skip it: their fog texels stay exact."""

from __future__ import annotations

import moderngl

from fogbank.render.gl import TEX
from fogbank.render.passes.base import Pass
from fogbank.render.programs import FULLSCREEN


def jittered(look) -> bool:
    """Is T sampled with a per-pixel jitter for this look (an enabled volume noise layer)?
    The cost model asks the same."""
    return any(l.enabled and l.kind == "noise" and l.mode == "volume" for l in look.layers)


def filter_fog(r, source, fbo) -> None:
    """The filter of `source` (a fog target's layout) into `fbo`: its sampled channels (T,
    T toward the sun and the in-scattered light, which follows T) averaged; the inverse
    distance passes through."""
    fbo.use()   # the particle quads draw into the bound target
    source.use(TEX["uFog"])
    r.programs.draw(r.programs.get(FULLSCREEN, "passes/fog_filter.frag"), moderngl.TRIANGLES)


class FogFilterPass(Pass):
    name = "fog_filter"
    reads = ("fog", "look")
    writes = ("fog",)

    def run(self, r, f) -> None:
        # a held fog's texels were filtered when it was drawn (passes/fog.py)
        if not jittered(f.still) or f.filtered:
            return
        fbo, tex = f.targets.fog_target(f.still.effects.fog_scale, 1)
        filter_fog(r, f.fog_tex, fbo)
        f.fog_tex = tex
