"""Render every preset's still (at two times, with each blur mode) into an .npz, and
compare two such files pixel by pixel: the check that a refactor changed no picture.

    PYTHONPATH=/path/to/old/server python scripts/preset_stills.py save old.npz
    python scripts/preset_stills.py save new.npz
    python scripts/preset_stills.py compare old.npz new.npz

Works with this layout (fogbank.render, fogbank.model) and the flat one before it.
"""

from __future__ import annotations

import sys

import numpy as np


def save(path: str) -> None:
    try:
        from fogbank.model import presets as P
        from fogbank.model.params import StillParams
        from fogbank.render.renderer import Renderer, create_context
    except ImportError:   # the flat layout before issue 10
        from fogbank import presets as P
        from fogbank.params import StillParams
        from fogbank.renderer import Renderer, create_context
    r = Renderer(create_context("egl"))
    imgs = {}
    for name in P.presets():
        d = P.preset_dict(name)
        for t in (0.0, 4.0):
            imgs[f"{name}@{t}"] = r.render(StillParams.model_validate({**d, "width": 480, "height": 270, "time": t}))
            for blur in ("single", "separate"):
                e = {**d.get("effects", {}), "blur": blur, "fog_scale": 2}
                s = StillParams.model_validate({**d, "width": 480, "height": 270, "time": t, "effects": e})
                imgs[f"{name}@{t}/{blur}"] = r.render(s)
    np.savez_compressed(path, **imgs)
    print(f"{path}: {len(imgs)} stills")


def compare(a_path: str, b_path: str) -> int:
    a, b = np.load(a_path), np.load(b_path)
    common = sorted(set(a.files) & set(b.files))
    worst = 0
    for k in common:
        d = int(np.abs(a[k].astype(np.int32) - b[k].astype(np.int32)).max())
        if d:
            print(f"{k}: max |difference| {d}/255")
        worst = max(worst, d)
    print(f"{len(common)} stills in both, max |difference| {worst}/255; only in the first: "
          f"{sorted(set(a.files) - set(b.files))}; only in the second: {sorted(set(b.files) - set(a.files))}")
    # a still missing from the second, or one more than 1/255 apart, fails
    return 1 if worst > 1 or set(a.files) - set(b.files) else 0


if __name__ == "__main__":
    if sys.argv[1] == "save":
        save(sys.argv[2])
    else:
        sys.exit(compare(sys.argv[2], sys.argv[3]))
