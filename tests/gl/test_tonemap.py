"""Exposure and tone mapping (render/shaders/common/tonemap.glsl) against float64 numpy
versions written here from the curves' specifications: the Khronos PBR Neutral
specification's steps, and AgX's published matrices (row by row, as the papers print
them; the GLSL writes them column by column) and sigmoid fit. Also what the curves
promise: Neutral keeps a base colour up to 0.76 (less its 0.04 toe offset) and never
shifts a hue; AgX keeps grey grey and is monotonic; both stay within [0, 1] however
bright the input."""

from __future__ import annotations

import moderngl
import numpy as np
import pytest

from fogbank.render.glsl import program
from fogbank.render.passes.output import TONE_MAPS

_FRAG = """
#include "common/tonemap.glsl"
uniform sampler2D uIn;
out vec4 fOut;
void main() {
    fOut = vec4(toneMap(texelFetch(uIn, ivec2(gl_FragCoord.xy), 0).rgb), 1.0);
}
"""


def _glsl(renderer, rgb: np.ndarray, curve: str, ev: float = 0.0) -> np.ndarray:
    ctx = renderer.ctx
    n = len(rgb)
    src = ctx.texture((n, 1), 3, rgb.astype(np.float32).tobytes(), dtype="f4")
    src.filter = (moderngl.NEAREST, moderngl.NEAREST)
    dst = ctx.texture((n, 1), 4, dtype="f4")
    fbo = ctx.framebuffer(color_attachments=[dst])
    prog = program(ctx, "passes/fullscreen.vert", "test_tonemap.frag", {"TONE_MAP": TONE_MAPS[curve]},
                   generated={"test_tonemap.frag": _FRAG})
    vao = ctx.vertex_array(prog, [])
    try:
        src.use(0)
        prog["uIn"].value = 0
        prog["uExposureScale"].value = 2.0 ** ev
        fbo.use()
        fbo.viewport = (0, 0, n, 1)
        vao.render(moderngl.TRIANGLES, vertices=3)
        return np.frombuffer(dst.read(), np.float32).reshape(n, 4)[:, :3].astype(np.float64)
    finally:
        renderer.caches.park()   # never release the bound framebuffer (render/targets.py)
        for o in (vao, prog, fbo, dst, src):
            o.release()


def neutral(c: np.ndarray) -> np.ndarray:
    """Khronos PBR Neutral, step by step as the specification writes it."""
    c = np.array(c, dtype=np.float64)
    out = np.empty_like(c)
    for i, (r, g, b) in enumerate(c):
        x = min(r, g, b)
        offset = x - 6.25 * x * x if x < 0.08 else 0.04
        col = np.array([r, g, b]) - offset
        peak = col.max()
        if peak < 0.76:
            out[i] = col
            continue
        d = 1.0 - 0.76
        new_peak = 1.0 - d * d / (peak + d - 0.76)
        col *= new_peak / peak
        gw = 1.0 - 1.0 / (0.15 * (peak - new_peak) + 1.0)
        out[i] = col * (1 - gw) + new_peak * gw
    return out


# AgX, the matrices row by row (linear BT.709 -> BT.2020 as ITU-R BT.2087 prints it, and
# the inset and outset of Blender's AgX base)
BT709_TO_BT2020 = np.array([[0.6274, 0.3293, 0.0433], [0.0691, 0.9195, 0.0113], [0.0164, 0.0880, 0.8956]])
BT2020_TO_BT709 = np.array([[1.6605, -0.5876, -0.0728], [-0.1246, 1.1329, -0.0083], [-0.0182, -0.1006, 1.1187]])
INSET = np.array([[0.856627153315983, 0.0951212405381588, 0.0482516061458583],
                  [0.137318972929847, 0.761241990602591, 0.101439036467562],
                  [0.11189821299995, 0.0767994186031903, 0.811302368396859]])
OUTSET = np.array([[1.1271005818144368, -0.11060664309660323, -0.016493938717834573],
                   [-0.1413297634984383, 1.157823702216272, -0.016493938717834257],
                   [-0.14132976349843826, -0.11060664309660294, 1.2519364065950405]])


def agx(c: np.ndarray) -> np.ndarray:
    lo, hi = np.log2(2.0 ** -10 * 0.18), np.log2(2.0 ** 6.5 * 0.18)
    x = (INSET @ BT709_TO_BT2020 @ np.asarray(c, dtype=np.float64).T).T
    x = np.clip((np.log2(np.maximum(x, 1e-10)) - lo) / (hi - lo), 0.0, 1.0)
    x = np.polyval([15.5, -40.14, 31.96, -6.868, 0.4298, 0.1191, -0.00232], x)
    x = np.maximum((OUTSET @ x.T).T, 0.0) ** 2.2
    return np.clip((BT2020_TO_BT709 @ x.T).T, 0.0, 1.0)


def _colours(seed: int = 3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.concatenate([rng.random((3000, 3)) * rng.choice([0.1, 1.0, 4.0, 40.0], (3000, 1)),
                           np.repeat(np.geomspace(1e-4, 1e3, 200)[:, None], 3, axis=1),
                           [[0.0, 0.0, 0.0], [0.079, 0.5, 0.3], [0.081, 0.5, 0.3], [0.8, 0.76, 0.9]]])


def test_the_matrices_as_written_keep_grey_and_the_log_range_is_the_published_one():
    for m in (BT709_TO_BT2020, BT2020_TO_BT709, INSET, OUTSET):
        assert np.abs(m.sum(axis=1) - 1.0).max() < 2e-4
    assert abs(np.log2(2.0 ** -10 * 0.18) - -12.47393) < 1e-5
    assert abs(np.log2(2.0 ** 6.5 * 0.18) - 4.026069) < 1e-5


# float32 against float64: Neutral is arithmetic; AgX takes a log2 and a power of 2.2,
# which llvmpipe evaluates to about 1e-6 relative (2.4e-5 seen after the sigmoid's
# slope). Either is far below an 8-bit level (3.9e-3).
TOLERANCE = {"neutral": 2e-6, "agx": 1e-4}


@pytest.mark.parametrize("curve,reference", [("neutral", neutral), ("agx", agx)])
def test_the_curve_matches_its_float64_reference(renderer, curve, reference):
    c = _colours()
    got = _glsl(renderer, c, curve)
    want = reference(c)
    assert np.abs(got - want).max() < TOLERANCE[curve]
    assert got.min() >= 0.0
    assert got.max() <= 1.0


def test_no_tone_map_is_the_exposed_light_unclipped(renderer):
    c = _colours()
    assert np.abs(_glsl(renderer, c, "none", ev=-1.5) - c * 2.0 ** -1.5).max() < 1e-6 * c.max()


@pytest.mark.parametrize("curve", ["neutral", "agx"])
def test_exposure_is_applied_before_the_curve(renderer, curve):
    c = _colours(9)[:500]
    want = {"neutral": neutral, "agx": agx}[curve](c * 2.0 ** 2.3)
    assert np.abs(_glsl(renderer, c, curve, ev=2.3) - want).max() < TOLERANCE[curve]


def test_neutral_keeps_base_colours_and_hue_and_rolls_highlights_off_toward_white(renderer):
    rng = np.random.default_rng(4)
    base = 0.08 + rng.random((500, 3)) * 0.7   # every channel in [0.08, 0.78): min >= 0.08, peak < 0.8
    got = _glsl(renderer, base, "neutral")
    assert np.abs(got - (base - 0.04)).max() < 1e-6
    # a hue held however bright: the channels' ratios (less the offset) before the mix to white
    # keep their order, and brighter in is brighter out, approaching 1 without reaching it
    ramp = np.array([[1.0, 0.5, 0.2]]) * np.geomspace(0.5, 200.0, 400)[:, None]
    out = _glsl(renderer, ramp, "neutral")
    assert (np.diff(out, axis=0) >= -1e-6).all()
    assert (out[:, 0] >= out[:, 1]).all() and (out[:, 1] >= out[:, 2]).all()
    assert out.max() < 1.0


def test_agx_keeps_grey_grey_and_is_monotonic(renderer):
    grey = np.repeat(np.geomspace(1e-4, 1e3, 300)[:, None], 3, axis=1)
    out = _glsl(renderer, grey, "agx")
    assert np.abs(out - out[:, :1]).max() < 5e-4
    assert (np.diff(out[:, 0]) >= -1e-6).all()
    mid = _glsl(renderer, np.array([[0.18, 0.18, 0.18]]), "agx")[0, 0]
    assert 0.15 < mid < 0.25   # middle grey stays near middle grey
