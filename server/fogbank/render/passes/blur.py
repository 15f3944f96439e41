"""The separate blur (blur "separate"): two 1D Gaussian passes, horizontal into the
second linear target and vertical into the output, sigma growing with the fog
(Gawron 3.3)."""

from __future__ import annotations

import moderngl

from fogbank.render.gl import TEX, set_uniforms
from fogbank.render.passes.base import Pass
from fogbank.render.passes.composite import blur_sigma
from fogbank.render.passes.output import output_defines, output_uniforms
from fogbank.render.programs import FULLSCREEN


class BlurPass(Pass):
    name = "blur"
    reads = ("linear",)
    writes = ("out",)

    def run(self, r, f) -> None:
        e = f.still.effects
        if e.blur != "separate":
            return
        (_, ta), (fb, tb) = f.targets.linear_pair()
        prog = r.programs.get(FULLSCREEN, "passes/blur.frag", **output_defines(f.still))
        set_uniforms(prog, {"uBlurSigma": blur_sigma(f), "uBlurExponent": e.blur_exponent,
                            **output_uniforms(f.still)})
        for src, dst, direction, final in ((ta, fb, (1.0, 0.0), False), (tb, f.targets.out, (0.0, 1.0), True)):
            # its taps read the mip level as wide as their gaps (passes/blur.frag)
            src.build_mipmaps()
            src.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
            dst.use()
            src.use(TEX["uImage"])
            set_uniforms(prog, {"uDirection": direction, "uFinal": final})
            r.programs.draw(prog, moderngl.TRIANGLES)
