"""The output: how linear light becomes the 8-bit image (exposure and tone map, for the
passes that write it: the composite, or the separate blur's last pass), and the readback.

Readback: the output target as (height, width, 3) uint8 sRGB (or 4, RGBX, for a frame
headed for the JPEG encoder: Frame.channels), top row first, into the frame size's kept buffer (render/targets.py Targets.readback): the frame's image is valid
until the next frame of that size (Renderer.render copies it unless told to lend it)."""

from __future__ import annotations

from fogbank.render.passes.base import Pass

# effects.tone_map -> common/tonemap.glsl TONE_MAP
TONE_MAPS = {"none": 0, "neutral": 1, "agx": 2}


def output_defines(look) -> dict:
    """The defines of a program that writes the 8-bit output (common/srgb.glsl outputColor)."""
    return {"TONE_MAP": TONE_MAPS[look.effects.tone_map]}


def output_uniforms(look) -> dict:
    """Its uniforms: the exposure, 2^EV."""
    return {"uExposureScale": 2.0 ** look.effects.exposure}


class OutputPass(Pass):
    name = "output"
    reads = ("out",)
    writes = ("image", "gbuffer.out_base")

    def run(self, r, f) -> None:
        if f.draft and not f.msaa and f.out_warp is None and f.still.effects.blur == "off":
            # a preview drawn whole (its scene pass perhaps warped, which is exact but for
            # resampling): what the next previews of its look warp (passes/warp_out.frag)
            f.gbuffer.keep_out_base(r.ctx, f.targets.out, f.view, f.look_key, f.still.time)
        f.image = f.targets.read_image(f.channels)
