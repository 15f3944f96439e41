"""Named looks. "default" is the base every URL and request patches; the others recreate
the seeds' figures on the countryside scene.

A preset is a patch over the model's field defaults (FogParams()); `resolve` merges a
patch over a preset: objects merge field by field, lists are replaced whole.
"""

from __future__ import annotations

import json
import math
from functools import lru_cache
from typing import Any

from fogbank.scene.landmarks import landmarks

PI = math.pi


def _house_chimney() -> tuple[float, float, float]:
    hx, hy, hz = landmarks().house
    return (hx + 2.65, hy + 7.2, hz - 0.75)


def _biri_fig6_layer(density: float = 0.012, scale: float = 150.0) -> dict:
    # K = 1 + 1/2 cos(5 pi y) + 1/5 cos(7 pi (y + 0.1 x)) + 1/5 cos(5 pi (y - 0.05 x))
    #       + 1/10 cos(pi x) cos(pi z / 2)      (the product expanded into two cosines)
    return {"kind": "cosine", "density": density, "c0": 1.0, "scale": scale, "wind": True,
            "terms": [{"amp": 0.5, "k": (0.0, 5 * PI, 0.0), "phase": 0.0},
                      {"amp": 0.2, "k": (0.7 * PI, 7 * PI, 0.0), "phase": 0.0},
                      {"amp": 0.2, "k": (-0.25 * PI, 5 * PI, 0.0), "phase": 0.0},
                      {"amp": 0.05, "k": (PI, 0.0, PI / 2), "phase": 0.0},
                      {"amp": 0.05, "k": (PI, 0.0, -PI / 2), "phase": 0.0}]}


def _presets() -> dict[str, dict[str, Any]]:
    hx, hy, hz = landmarks().house
    bx, by, bz = landmarks().bridge
    fx, fy, fz = landmarks().forest
    view = {"position": (-15.0, 34.0, 95.0), "yaw": 5.0, "pitch": -13.0, "fov": 60.0}
    house_view = {"position": (-58.0, 22.0, 12.0), "yaw": 25.0, "pitch": -8.0, "fov": 55.0}
    smoke = {"kind": "particles", "count": 64, "emitter": _house_chimney(), "direction": (0.0, 1.0, 0.0),
             "spread": 12.0, "speed": 2.2, "life_min": 8, "life_max": 16, "step": 0.45,
             "radius": 1.6, "alpha": 0.85, "drag": 0.35, "gravity": 0.3, "wind": True, "seed": 3}
    return {
        "default": {
            "title": "Valley mist at sunrise",
            "source": "fogbank's own mix: exponential height fog (Unreal, Filament), Biri et al. 2002 cosines and a point potential, Fischer's particles, Gawron's and Henyey-Greenstein's in-scattering",
            "description": "A low sun through ground mist pooled in the river valley (height fog), "
                           "drifting Biri cosine layers, denser air in the forest (a point "
                           "potential) and chimney smoke; Henyey-Greenstein in-scattering, the "
                           "sunlight dimmed by the fog, and sampled light shafts between the trees.",
            "params": {
                "camera": {"position": (-35.0, 36.0, 85.0), "yaw": 30.0, "pitch": -11.0, "fov": 60.0},
                "fog_color": "#aab6c2",
                "sun": {"azimuth": 30.0, "elevation": 9.0, "color": "#ffd9a8", "intensity": 3.4},
                "effects": {"phase": "henyey-greenstein", "anisotropy": 0.6, "scatter": 0.04,
                            "shafts": 1.0, "sun_through_fog": True, "sky_distance": 400.0,
                            "fog_scale": 2},
                "layers": [
                    {"kind": "height", "density": 0.025, "falloff": 0.2, "base": 1.0},
                    _biri_fig6_layer(0.0025, 24.0),
                    {"kind": "potential", "shape": "point", "center": (fx, fy, fz), "strength": 0.6,
                     "c": 30.0, "e": 0.05},
                    smoke,
                ],
            },
        },
        "biri-fig6": {
            "title": "Biri et al. 2002, figure 6",
            "source": "Biri, Michelin & Arquès, Real-Time Animation of Realistic Fog (2002): figure 6, section 3.2.1",
            "description": "Layers of mist from four cosine functions plus one constant (the "
                           "product term expanded into two cosines), 150 m per function unit: "
                           "dense in the valley, clear on the hilltops, tilted and drifting.",
            "params": {"camera": view, "layers": [_biri_fig6_layer()],
                       "effects": {"cutoff_distance": 500.0, "cutoff_mode": "fog"}},
        },
        "biri-fig7": {
            "title": "Biri et al. 2002, figure 7",
            "source": "Biri, Michelin & Arquès 2002: figure 7, section 3.2.2",
            "description": "Two fourth-degree polynomials {0.8, -1, 0, 0, 1} on X and Z, mirrored "
                           "at their tile borders (no seam), their minimum on the house: its middle "
                           "is clear, its ends in mist.",
            "params": {"camera": house_view,
                       "effects": {"cutoff_distance": 500.0, "cutoff_mode": "fog"},
                       "layers": [
                           {"kind": "polynomial", "density": 0.014, "coeffs": [0.8, -1.0, 0.0, 0.0, 1.0],
                            "axis": (1 / 12.0, 0.0, 0.0), "offset": 0.63 - hx / 12.0, "half_width": 1.0},
                           {"kind": "polynomial", "density": 0.014, "coeffs": [0.8, -1.0, 0.0, 0.0, 1.0],
                            "axis": (0.0, 0.0, 1 / 12.0), "offset": 0.63 - hz / 12.0, "half_width": 1.0}]},
        },
        "biri-fig8": {
            "title": "Biri et al. 2002, figure 8",
            "source": "Biri, Michelin & Arquès 2002: figure 8, section 3.2.3 (eq. 9)",
            "description": "Thin constant fog with four tight point potentials centred on trees: the mist "
                           "gathers around them.",
            "params": {"camera": {"position": (30.0, 35.0, 60.0), "yaw": 7.0, "pitch": -10.0, "fov": 55.0},
                       "effects": {"cutoff_distance": 500.0, "cutoff_mode": "fog"},
                       "layers": [{"kind": "homogeneous", "density": 0.003}] + [
                           {"kind": "potential", "shape": "point", "center": c, "strength": 0.35,
                            "c": 2.5, "e": 0.1} for c in landmarks().trees]},
        },
        "quilez-spheres": {
            "title": "Quilez: analytic fog spheres",
            "source": "Inigo Quilez, analytically integrated volumetric media (no raymarching)",
            "description": "Spheres of fog, density 1 - r^2, integrated in closed form and "
                           "clipped by the depth buffer.",
            "params": {"camera": view, "layers": [
                {"kind": "sphere", "center": (hx, hy, hz), "radius": 16.0, "density": 0.12},
                {"kind": "sphere", "center": (bx, by + 2.0, bz), "radius": 14.0, "density": 0.15},
                {"kind": "sphere", "center": (fx, fy, fz), "radius": 30.0, "density": 0.06}]},
        },
        "fischer-fog": {
            "title": "Fischer: particle fog",
            "source": "Cameron Fischer, Clouds, Fog, and Smoke",
            "description": "Ground fog over the river from 400 free particles born along it "
                           "(life 64-128 steps, max opacity 0.2 each), drifting with the wind.",
            "params": {"camera": view, "time": 40.0, "wind": {"direction": 100.0, "speed": 0.8},
                       "layers": [{"kind": "particles", "count": 400, "emitter": (10.0, 1.5, -15.0),
                                   "emitter_size": (16.0, 1.0, 85.0),
                                   "direction": (0.0, 1.0, 0.0), "spread": 80.0, "speed": 0.3,
                                   "life_min": 64, "life_max": 128, "step": 0.25, "radius": 7.0,
                                   "alpha": 0.2, "drag": 0.3, "gravity": -0.02, "wind": True,
                                   "seed": 11}]},
        },
        "fischer-smoke": {
            "title": "Fischer: chimney smoke",
            "source": "Cameron Fischer, Clouds, Fog, and Smoke",
            "description": "Smoke from a few particles (life 8-16 steps, opacity near 1) out of "
                           "the house's chimney, bent by the wind.",
            "params": {"camera": house_view, "time": 12.0, "wind": {"direction": 80.0, "speed": 2.0},
                       "layers": [smoke]},
        },
        "perlin-fog": {
            "title": "Perlin fog with height falloff",
            "source": "Perlin Fog (course project write-up)",
            "description": "The course write-up's fog: baked fractal Perlin noise, "
                           "f = exp(-rho d n), n -> n dY^2 / 2 + 0.001, drifting with the wind.",
            "params": {"camera": {"position": (-30.0, 60.0, 120.0), "yaw": 12.0, "pitch": -20.0, "fov": 60.0},
                       "layers": [{"kind": "noise", "mode": "surface", "density": 0.004, "scale": 70.0,
                                   "height_falloff": True, "falloff_scale": 20.0, "wind": True}]},
        },
        "fog-volumes": {
            "title": "Fog volumes: a box and an ellipsoid",
            "source": "fogbank: closed-form chords through a box and an ellipsoid (the sphere's profile of Quilez)",
            "description": "A rotated box of constant fog lying along the river at the bridge "
                           "(tau = rho times the chord, slab method) and an ellipsoidal cloud over "
                           "the forest (the sphere's 1 - r^2 profile in the ellipsoid's metric), "
                           "over a thin ground haze.",
            "params": {"camera": view,
                       "layers": [
                           {"kind": "height", "density": 0.006, "falloff": 0.08, "base": 0.0},
                           {"kind": "box", "center": (bx, 3.0, bz - 25.0), "half_size": (14.0, 5.0, 45.0),
                            "yaw": -12.0, "density": 0.07},
                           {"kind": "ellipsoid", "center": (fx, fy + 6.0, fz), "radii": (38.0, 9.0, 24.0),
                            "yaw": 30.0, "pitch": 6.0, "density": 0.16}]},
        },
        "carved-clearing": {
            "title": "A clearing carved out of the fog",
            "source": "fogbank: a negative-density ellipsoid subtracted from height fog",
            "description": "Dense valley fog with an ellipsoid of negative density around the "
                           "house (Biri's subtracted objects, Godot's negative FogVolume): the "
                           "fog is carved away there, and the total optical depth never drops "
                           "below 0.",
            "params": {"camera": house_view,
                       "layers": [
                           {"kind": "height", "density": 0.05, "falloff": 0.04, "base": 0.0},
                           {"kind": "ellipsoid", "center": (hx, hy, hz), "radii": (22.0, 14.0, 22.0),
                            "density": 0.0, "carve": 1.0, "edge_fade": 0.6}]},
        },
        "gawron-distance": {
            "title": "Gawron & Boryczka 2018: distance fog",
            "source": "Gawron & Boryczka, Heterogeneous Fog Generated with the Effect of Light Scattering and Blur (2018): sections 3.1-3.3",
            "description": "Distance fog with noise-varied density, an orange scatter colour of "
                           "its own in the sun's direction (eqs. 5-8, with the scatter start "
                           "distance), its noise drifting on its own (not with the wind) and a "
                           "Gaussian blur that grows with the fog.",
            "params": {"camera": view, "fog_color": "#a9bcd9",
                       "sun": {"azimuth": 30.0, "elevation": 9.0, "color": "#fff1d6", "intensity": 3.0},
                       "effects": {"scatter": 0.25, "scatter_exponent": 4.0, "scatter_color": "#ffa647",
                                   "scatter_start": 20.0, "blur": "single", "blur_radius": 3.0},
                       "layers": [{"kind": "distance", "start": 10.0, "distance": 260.0, "exponent": 0.55,
                                   "low": 0.8, "high": 1.2, "max": 0.75, "noise_scale": 90.0, "wind": False,
                                   "drift": (2.0, 0.0, -1.0)}]},
        },
    }


@lru_cache(maxsize=1)
def presets() -> dict[str, dict[str, Any]]:
    return _presets()


def merge(base: Any, patch: Any) -> Any:
    """Objects merge key by key; anything else (lists included) replaces."""
    if isinstance(base, dict) and isinstance(patch, dict):
        out = dict(base)
        for k, v in patch.items():
            out[k] = merge(base.get(k), v) if k in base else v
        return out
    return patch


def patched(patch: dict, base: dict | None = None, cls=None):
    """A look: `patch` merged over `base` (by default the default preset), validated as
    `cls` (FogParams by default). The one place a patch meets its base: REST bodies, the
    WebSocket's params and camera messages and the presets themselves come through here.
    Raises pydantic's ValidationError, each error's loc relative to the look."""
    from fogbank.model.params import FogParams
    cls = cls or FogParams
    return cls.model_validate(merge(preset_dict("default") if base is None else base, patch))


@lru_cache(maxsize=32)
def _preset_json(name: str) -> str:
    from fogbank.model.params import FogParams
    if name not in presets():
        raise KeyError(name)
    return patched(presets()[name]["params"], FogParams().model_dump(mode="json")).model_dump_json()


def preset_dict(name: str) -> dict:
    """The preset's full params as a fresh plain dict (validated once, safe to mutate)."""
    return json.loads(_preset_json(name))
