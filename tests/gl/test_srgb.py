"""The output's sRGB encoding (render/shaders/common/srgb.glsl linearToSrgb, a fit of the
power with square roots) against the IEC 61966-2-1 curve in float64, over [0, 1] and
round the linear segment's end, and clamped outside."""

from __future__ import annotations

import moderngl
import numpy as np

from fogbank.render.glsl import program

_FRAG = """
#include "common/srgb.glsl"
uniform sampler2D uIn;
out vec4 fOut;
void main() {
    fOut = vec4(linearToSrgb(vec3(texelFetch(uIn, ivec2(gl_FragCoord.xy), 0).r)), 1.0);
}
"""


def _encode(renderer, c: np.ndarray) -> np.ndarray:
    ctx = renderer.ctx
    n = c.size
    src = ctx.texture((n, 1), 1, c.astype(np.float32).tobytes(), dtype="f4")
    src.filter = (moderngl.NEAREST, moderngl.NEAREST)
    dst = ctx.texture((n, 1), 4, dtype="f4")
    fbo = ctx.framebuffer(color_attachments=[dst])
    prog = program(ctx, "passes/fullscreen.vert", "test_srgb.frag", generated={"test_srgb.frag": _FRAG})
    vao = ctx.vertex_array(prog, [])
    try:
        src.use(0)
        prog["uIn"].value = 0
        fbo.use()
        fbo.viewport = (0, 0, n, 1)
        vao.render(moderngl.TRIANGLES, vertices=3)
        return np.frombuffer(dst.read(), np.float32).reshape(n, 4)[:, 0].astype(np.float64)
    finally:
        renderer.caches.park()   # never release the bound framebuffer (render/targets.py)
        for o in (vao, prog, fbo, dst, src):
            o.release()


def _iec(c: np.ndarray) -> np.ndarray:
    c = np.clip(c, 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)


def test_the_encoding_is_within_a_hundredth_of_a_level_of_the_iec_curve_and_keeps_white(renderer):
    rng = np.random.default_rng(5)
    c = np.concatenate([np.linspace(0.0, 1.0, 4001), rng.random(4000), rng.random(2000) ** 6,
                        np.linspace(0.0031, 0.0032, 201)])   # round the linear segment's end
    got = _encode(renderer, c)
    assert np.abs(got - _iec(c)).max() * 255 < 0.01
    ends = _encode(renderer, np.array([0.0, 1.0]))
    assert abs(ends[0]) < 1e-7
    assert abs(ends[1] - 1.0) < 1e-6   # white stays white: no pixel of it dithers down to 254
    assert renderer.ctx.error == "GL_NO_ERROR"


def test_the_encoding_clamps_outside_zero_to_one(renderer):
    got = _encode(renderer, np.array([-1.0, -1e-3, 1.5, 40.0]))
    assert np.abs(got - np.array([0.0, 0.0, 1.0, 1.0])).max() * 255 < 0.01
