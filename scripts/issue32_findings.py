"""Issue 32's findings, each at its camera, rendered by the code on PYTHONPATH (this
checkout's, or an earlier one's `server` folder), so that before and after are the same
script: `python scripts/issue32_findings.py OUT` writes OUT/NAME.png (1280x720, or the
finding's crop). `--pair BEFORE AFTER DEST` lays each pair side by side into DEST as JPEG.

    PYTHONPATH=/tmp/before/server python scripts/issue32_findings.py /tmp/f32-before
    python scripts/issue32_findings.py /tmp/f32-after
    python scripts/issue32_findings.py --pair /tmp/f32-before /tmp/f32-after docs/issue32

Each look is a preset of the code that renders it (its own presets: before is the look
as it was) with only fields both versions know patched in."""

from __future__ import annotations

import sys
from pathlib import Path

from PIL import Image, ImageDraw

W, H = 1280, 720

# name: (preset, patch, crop (x0, y0, x1, y1) in the 1280x720 frame or None, caption)
FINDINGS = {
    "sun": ("default", {}, (640, 0, 1280, 360),
            "the sun: a clipped patch (3.2% of the frame at 255) before; tone mapped after"),
    "edge-south": ("default", {"camera": {"position": (0.0, 40.0, 120.0), "yaw": 180.0, "pitch": -5.0, "fov": 60.0}},
                   None, "the world's edge from (0, 40, 120) looking south: a dark wall before"),
    "edge-west": ("default", {"camera": {"position": (-120.0, 40.0, 0.0), "yaw": 270.0, "pitch": -5.0, "fov": 60.0}},
                  None, "from (-120, 40, 0) looking west"),
    "edge-high": ("default", {"camera": {"position": (0.0, 600.0, 0.0), "yaw": 30.0, "pitch": -12.0, "fov": 60.0}},
                  None, "from 600 m up: the far land's polygon edge and a grey void below the horizon before"),
    "edge-bounds": ("default", {"camera": {"position": (0.0, 21.0, -660.0), "yaw": 180.0, "pitch": -4.0, "fov": 60.0}},
                    None, "3 m above the ground at the camera bounds' edge: the far land's facets overhead before"),
    "carving": ("carved-clearing", {}, None,
                "carving: the house a cut-out through 22 m of fog before; a clearing inside standing fog after"),
    "blur": ("default", {"effects": {"blur": "separate", "blur_radius": 12.0}}, (0, 150, 640, 510),
             "the separate blur at radius 12: stripe-shaped ghosts at the house before"),
    "noise": ("default", {"layers": [{"kind": "noise", "mode": "surface", "density": 0.004, "scale": 70.0,
                                      "height_falloff": True, "falloff_scale": 20.0, "wind": True}],
                          "camera": {"position": (-30.0, 60.0, 120.0), "yaw": 12.0, "pitch": -8.0, "fov": 60.0}},
              (320, 180, 960, 540), "surface noise far away: salt and pepper on the far hills before"),
}


def merge(a: dict, b: dict) -> dict:
    out = dict(a)
    for k, v in b.items():
        out[k] = merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def render(out: Path) -> None:
    from fogbank.model.params import StillParams
    from fogbank.model.presets import preset_dict
    from fogbank.render.renderer import Renderer, create_context
    r = Renderer(create_context("egl"))
    out.mkdir(parents=True, exist_ok=True)
    for name, (preset, patch, crop, _) in FINDINGS.items():
        look = merge(preset_dict(preset), patch)
        img = Image.fromarray(r.render(StillParams.model_validate({**look, "width": W, "height": H})))
        if crop:
            img = img.crop(crop)
        img.save(out / f"{name}.png")
        print(name, img.size)


def pair(before: Path, after: Path, dest: Path) -> None:
    dest.mkdir(parents=True, exist_ok=True)
    for name, (*_, caption) in FINDINGS.items():
        a, b = Image.open(before / f"{name}.png"), Image.open(after / f"{name}.png")
        w, h = a.size
        scale = 640 / w if w > 640 else 1.0
        a, b = (im.resize((round(w * scale), round(h * scale)), Image.LANCZOS) for im in (a, b))
        sheet = Image.new("RGB", (2 * a.width + 8, a.height + 22), (255, 255, 255))
        sheet.paste(a, (0, 22))
        sheet.paste(b, (a.width + 8, 22))
        d = ImageDraw.Draw(sheet)
        d.text((4, 4), "before (e1719c8)", fill=(0, 0, 0))
        d.text((a.width + 12, 4), "after", fill=(0, 0, 0))
        sheet.convert("RGB").save(dest / f"{name}-before-after.jpg", quality=85)
        print(dest / f"{name}-before-after.jpg", "-", caption)


if __name__ == "__main__":
    if sys.argv[1] == "--pair":
        pair(Path(sys.argv[2]), Path(sys.argv[3]), Path(sys.argv[4]))
    else:
        render(Path(sys.argv[1]))
