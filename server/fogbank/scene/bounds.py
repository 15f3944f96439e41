"""Where the page lets the camera go in each scene: over the land it draws and a margin
round it, between the water (or the ground) and a height from which the scene still
fills the view. The schema carries them (FogParams' `camera_bounds`), so the page clamps
drags, flights and typed positions to the scene instead of losing it (an eye 1e12 m out
sees nothing). The params model's own bound (fields.POSITION_LIMIT) is the accuracy
domain, wider than any scene."""

from __future__ import annotations

from fogbank.scene import terrain

# (min xyz, max xyz), metres
CAMERA_BOUNDS: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {
    # the detailed terrain is [-EXTENT, EXTENT]; three times that keeps it in view
    "countryside": ((-3 * terrain.EXTENT, terrain.WATER_LEVEL - 5.0, -3 * terrain.EXTENT),
                    (3 * terrain.EXTENT, 800.0, 3 * terrain.EXTENT)),
    # the ground plane is +-2000 m; its boxes stand within 120 m of the origin
    "calibration": ((-1000.0, 0.1, -1000.0), (1000.0, 800.0, 1000.0)),
}


def camera_bounds_schema() -> dict:
    return {name: {"min": list(lo), "max": list(hi)} for name, (lo, hi) in CAMERA_BOUNDS.items()}
