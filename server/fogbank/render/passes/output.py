"""Readback: the output target as (height, width, 3) uint8 sRGB (or 4, RGBX, for a frame
headed for the JPEG encoder: Frame.channels), top row first, into the frame size's kept buffer (render/targets.py Targets.readback): the frame's image is valid
until the next frame of that size (Renderer.render copies it unless told to lend it)."""

from __future__ import annotations

from fogbank.render.passes.base import Pass


class OutputPass(Pass):
    name = "output"
    reads = ("out",)
    writes = ("image",)

    def run(self, r, f) -> None:
        f.image = f.targets.read_image(f.channels)
