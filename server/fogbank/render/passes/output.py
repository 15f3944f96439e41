"""Readback: the output target as (height, width, 3) uint8 sRGB, top row first."""

from __future__ import annotations

import numpy as np

from fogbank.render.passes.base import Pass


class OutputPass(Pass):
    name = "output"
    reads = ("out",)
    writes = ("image",)

    def run(self, r, f) -> None:
        w, h = f.targets.size
        raw = f.targets.out.read(components=3, alignment=1)
        f.image = np.frombuffer(raw, np.uint8).reshape(h, w, 3)[::-1]
