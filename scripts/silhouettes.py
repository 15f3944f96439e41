"""Silhouette error of a preset against a supersampled render, in linear levels of 255:
the look at 320x180 with MSAA (blur off, fog_scale 1) against the same look at 4x the
size without MSAA, read at the four standard 4x MSAA sample positions of each pixel.
Silhouette pixels are those whose 4x4 block of the large render spans inverse distances
more than 50% apart. Prints the mean signed error and RMS there, and the RMS elsewhere.

    .venv/bin/python scripts/silhouettes.py fog-volumes default perlin-fog
    PYTHONPATH=/path/to/other/checkout/server .venv/bin/python scripts/silhouettes.py fog-volumes
"""

from __future__ import annotations

import sys

import numpy as np

W, H, S = 320, 180, 4
STANDARD_4X = ((3, 1), (7, 3), (1, 5), (5, 7))   # eighths of a pixel from its bottom-left


def linear(u8: np.ndarray) -> np.ndarray:
    c = u8.astype(np.float64) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def main(names: list[str]) -> None:
    from fogbank.model.params import StillParams
    from fogbank.model.presets import preset_dict
    from fogbank.render.renderer import Renderer, create_context
    r = Renderer(create_context("egl"))
    for name in names:
        base = preset_dict(name)
        eff = {**base.get("effects", {}), "blur": "off", "fog_scale": 1}
        lo = StillParams.model_validate({**base, "width": W, "height": H, "effects": eff})
        hi = StillParams.model_validate({**base, "width": W * S, "height": H * S, "effects": eff})
        small = linear(r.render(lo, slot="lo", msaa=True))
        big = r.render(hi, slot="hi", msaa=False)
        g = r.caches.gbuffer("hi", W * S, H * S, hi.effects.sun_through_fog)
        inv = np.frombuffer(g.invdist.read(), np.float32).reshape(H * S, W * S)[::-1].reshape(H, S, W, S)
        mx, mn = inv.max(axis=(1, 3)), inv.min(axis=(1, 3))
        sil = (mx - mn) / np.maximum(mx, 1e-6) > 0.5
        blocks = linear(big).reshape(H, S, W, S, 3)                  # rows top first
        ref = np.mean([blocks[:, S - 1 - y // 2, :, x // 2] for x, y in STANDARD_4X], axis=0)
        err = (small - ref).mean(axis=2) * 255
        print(f"{name:16s} silhouette px {int(sil.sum()):4d}  mean signed {err[sil].mean():6.2f}  "
              f"RMS {np.sqrt((err[sil] ** 2).mean()):5.2f}  elsewhere RMS {np.sqrt((err[~sil] ** 2).mean()):5.2f}")


if __name__ == "__main__":
    main(sys.argv[1:] or ["fog-volumes"])
