"""The jittered fog's filter (passes/fog_filter.frag): for looks whose fog pass samples
with a per-pixel jitter (volume noise, light shafts), a 3x3 depth-aware mean of the fog
target into a second one, which the particle quads and the composite then use. Looks
with closed forms only skip it: their fog texels stay exact."""

from __future__ import annotations

import moderngl

from fogbank.render.gl import TEX
from fogbank.render.passes.base import Pass
from fogbank.render.programs import FULLSCREEN


def jittered(look) -> bool:
    """Does the fog pass sample with a per-pixel jitter for this look (light shafts, or an
    enabled volume noise layer)? The cost model asks the same."""
    return look.effects.shafts > 0 or any(
        l.enabled and l.kind == "noise" and l.mode == "volume" for l in look.layers)


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
        r.programs.draw(r.programs.get(FULLSCREEN, "passes/fog_filter.frag"), moderngl.TRIANGLES)
        f.fog_tex = tex
