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


# The look most presets share: light in the fog (single scattering: each point lit by the
# sun through the fog toward it and shadowed by the scene), the sky in the fog at distance,
# and a filmic tone map that rolls the sun's glow off instead of clipping it. The papers'
# own flat fog is one switch away (effects.lit off, effects.shafts 0, tone_map "none").
LIT = {"lit": True, "shafts": 1.0, "sun_through_fog": True, "tone_map": "neutral", "aerial_perspective": 0.6,
       "phase": "henyey-greenstein", "anisotropy": 0.55}


def lit(**effects) -> dict:
    return {**LIT, **effects}


def _presets() -> dict[str, dict[str, Any]]:
    hx, hy, hz = landmarks().house
    bx, by, bz = landmarks().bridge
    fx, fy, fz = landmarks().forest
    view = {"position": (-15.0, 34.0, 95.0), "yaw": 5.0, "pitch": -13.0, "fov": 60.0}
    house_view = {"position": (-58.0, 22.0, 12.0), "yaw": 25.0, "pitch": -8.0, "fov": 55.0}
    cx, cy, cz = _house_chimney()
    # born 0.8 m down the chimney (its top is cy + 0.4): a newborn fades in over its first
    # 2 steps (kinds/particle_motion.py FADE_IN_STEPS, 1.4 m at 2.4 m/s), which left a gap
    # between the chimney and the smoke when born above it; a 28 degree cone and lives to
    # 13 s spread the plume from the chimney's width to about 6 m (at 14 degrees and 11 s
    # it stayed a tube)
    smoke = {"kind": "particles", "count": 160, "emitter": (cx, cy - 0.8, cz), "direction": (0.0, 1.0, 0.0),
             "spread": 28.0, "speed": 2.4, "life_min": 20, "life_max": 44, "step": 0.3,
             "radius": 2.0, "alpha": 0.7, "drag": 0.45, "gravity": 0.5, "wind": True, "seed": 3}
    return {
        "default": {
            "title": "Valley mist at sunrise",
            "source": "fogbank's own mix: exponential height fog (Unreal, Filament), Biri et al. 2002 cosines and a point potential, Fischer's particles, Gawron's and Henyey-Greenstein's in-scattering",
            "description": "A low sun through ground mist pooled in the river valley (height fog), "
                           "drifting Biri cosine layers, denser air in the forest (a point "
                           "potential) and chimney smoke, all lit by the sun through the fog: "
                           "the trees' shadows fall through the mist as shafts, the smoke shades "
                           "itself, and the far hills fade into the sky.",
            "params": {
                "camera": {"position": (-35.0, 36.0, 85.0), "yaw": 30.0, "pitch": -11.0, "fov": 60.0},
                "fog_color": "#8593a4",
                "sun": {"azimuth": 30.0, "elevation": 9.0, "color": "#ffd9a8", "intensity": 3.4},
                "effects": lit(anisotropy=0.6, scatter=0.07, sky_distance=400.0, fog_scale=2),
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
                           "bands of mist stacked up the valley's sides, lit from above and "
                           "shaded beneath, clear between them, tilted and drifting with the wind.",
            "params": {"camera": view,
                       "sun": {"azimuth": 210.0, "elevation": 28.0},
                       "fog_color": "#7c8794",
                       "layers": [_biri_fig6_layer(0.015)],
                       "effects": lit(scatter=0.12, anisotropy=0.4, sky_distance=250.0, cutoff_distance=240.0,
                                      cutoff_mode="fog")},
        },
        "biri-fig7": {
            "title": "Biri et al. 2002, figure 7",
            "source": "Biri, Michelin & Arquès 2002: figure 7 (and figure 5's wind), section 3.2.2",
            "description": "Two fourth-degree polynomials {0.8, -1, 0, 0, 1} on X and Z, mirrored "
                           "at their tile borders (no seam), their minimum on the house: its middle "
                           "is clear, its ends in mist. The wind slides the Z waves along "
                           "(figure 5's animation by the phase), the house's clear middle stays.",
            "params": {"camera": {"position": (hx, hy + 5.0, hz + 60.0), "yaw": 0.0, "pitch": -3.0,
                                  "fov": 32.0},
                       "sun": {"azimuth": 150.0, "elevation": 35.0},
                       "wind": {"direction": 0.0, "speed": 3.0},
                       "fog_color": "#8b95a1",
                       "effects": lit(scatter=0.12, sky_distance=250.0, cutoff_distance=240.0, cutoff_mode="fog"),
                       # 2.7 m a unit on X: the wall's ends (4.3 m out) lie toward the tile's
                       # dense side (P 2.7 and, mirrored, 1.0 against the middle's 0.33), a
                       # wave of mist either side as in the figure; at 11.6 m a unit they
                       # were P 0.55 and 0.8, and the wall read as evenly veiled
                       "layers": [
                           {"kind": "polynomial", "density": 0.02, "coeffs": [0.8, -1.0, 0.0, 0.0, 1.0],
                            "axis": (1 / 2.7, 0.0, 0.0), "offset": 0.63 - hx / 2.7, "half_width": 1.0},
                           {"kind": "polynomial", "density": 0.007, "coeffs": [0.8, -1.0, 0.0, 0.0, 1.0],
                            "axis": (0.0, 0.0, 1 / 12.0), "offset": 0.63 - hz / 12.0, "half_width": 1.0,
                            "wind": True}]},
        },
        "biri-fig8": {
            "title": "Biri et al. 2002, figure 8",
            "source": "Biri, Michelin & Arquès 2002: figure 8, section 3.2.3 (eq. 9)",
            "description": "Thin constant fog with four tight point potentials centred on trees: the mist "
                           "gathers around them, lit where the sun reaches it.",
            "params": {"camera": {"position": (30.0, 35.0, 60.0), "yaw": 7.0, "pitch": -10.0, "fov": 55.0},
                       "sun": {"azimuth": 150.0, "elevation": 22.0},
                       "fog_color": "#7f8a97",
                       "effects": lit(scatter=0.12, sky_distance=250.0, cutoff_distance=240.0, cutoff_mode="fog"),
                       "layers": [{"kind": "homogeneous", "density": 0.0015}] + [
                           {"kind": "potential", "shape": "point", "center": c, "strength": 0.5,
                            "c": 2.0, "e": 0.25} for c in landmarks().trees]},
        },
        "quilez-spheres": {
            "title": "Quilez: analytic fog spheres",
            "source": "Inigo Quilez, analytically integrated volumetric media (no raymarching)",
            "description": "Spheres of fog, density 1 - r^2, integrated in closed form and "
                           "clipped by the depth buffer, lit by the sun through themselves: "
                           "bright on the sun's side, shaded on the other.",
            "params": {"camera": view, "sun": {"azimuth": 250.0, "elevation": 25.0},
                       "effects": lit(scatter=0.25, anisotropy=0.3, aerial_perspective=0.4),
                       "fog_color": "#7a8595",
                       "layers": [
                {"kind": "sphere", "center": (hx, hy, hz), "radius": 16.0, "density": 0.12},
                {"kind": "sphere", "center": (bx, by + 2.0, bz), "radius": 14.0, "density": 0.15},
                {"kind": "sphere", "center": (fx, fy, fz), "radius": 30.0, "density": 0.06}]},
        },
        "fischer-fog": {
            "title": "Fischer: particle fog",
            "source": "Cameron Fischer, Clouds, Fog, and Smoke",
            "description": "Ground fog over the river from 400 free particles born along it "
                           "(life 64-128 steps, max opacity 0.2 each), drifting with the wind; "
                           "a low sun from the west leaves the valley floor in the hills' shade, "
                           "and the fog there is darker than the fog in the sun.",
            "params": {"camera": view, "time": 40.0, "wind": {"direction": 100.0, "speed": 0.8},
                       "sun": {"azimuth": 255.0, "elevation": 10.0},
                       "fog_color": "#66717f",
                       "effects": lit(scatter=0.2, anisotropy=0.3),
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
            "description": "Wood smoke from 140 particles out of the house's chimney, each "
                           "born thin and widening seven times over its life, rising warm and "
                           "bent over by the wind: grey and dark where it is thick (it shades "
                           "itself), lit on the sun's side, thinning out as it drifts off.",
            "params": {"camera": {**house_view, "yaw": 35.0, "pitch": -4.0}, "time": 12.0,
                       "wind": {"direction": 80.0, "speed": 3.0},
                       "sun": {"azimuth": 120.0, "elevation": 30.0},
                       "fog_color": "#6f747c",
                       "effects": lit(scatter=0.3, anisotropy=0.3, aerial_perspective=0.0, shafts=1.0),
                       # A fresh eye saw the smoke as steam (brighter than the sky behind
                       # it), no chimney (the smoke's first puff hid it), a blob over the
                       # roof, cotton-ball puffs, rising straight out of the frame. Each
                       # particle is now born 0.8 m wide and grows to 5.6 m (growth 7: the
                       # plume widens as it goes instead of starting at its full width),
                       # fewer and more opaque (140, 0.8: it keeps lumps), greyer (the fog
                       # colour is the smoke's), lives 6-15 s and is bent by a 3 m/s wind,
                       # framed so that the whole plume stays in view
                       # (test_fischer_smoke_reads_as_smoke_from_a_chimney)
                       "layers": [{**smoke, "count": 140, "alpha": 0.8, "radius": 0.55, "growth": 10.0,
                                   "spread": 25.0, "life_min": 20, "life_max": 50, "speed": 2.5,
                                   "drag": 0.45, "gravity": 0.7}]},
        },
        "perlin-fog": {
            "title": "Perlin fog, as an artist sets it up",
            "source": "Perlin Fog (course project write-up): its baked fractal noise and quadratic height falloff",
            "description": "The write-up's baked fractal Perlin noise, integrated through the "
                           "volume (not painted on the ground as its surface mode does), drifting "
                           "with the wind over a ground mist, and lit by the sun: patches of "
                           "mist that shade one another. The write-up's own surface mode is a "
                           "layer's mode away.",
            "params": {"camera": {"position": (-30.0, 40.0, 120.0), "yaw": 12.0, "pitch": -12.0, "fov": 60.0},
                       "sun": {"azimuth": 200.0, "elevation": 20.0},
                       "fog_color": "#7c8896",
                       "effects": lit(scatter=0.12),
                       "layers": [{"kind": "height", "density": 0.02, "falloff": 0.15, "base": 2.0},
                                  {"kind": "noise", "mode": "volume", "density": 0.012, "scale": 45.0,
                                   "wind": True, "samples": 12}]},
        },
        "fog-volumes": {
            "title": "Fog volumes: a box and an ellipsoid",
            "source": "fogbank: closed-form chords through a box and an ellipsoid (the sphere's profile of Quilez)",
            "description": "A rotated box of fog lying along the river at the bridge, its faces "
                           "faded (Godot's edge fade: exact, a cubic between the fade's kinks), "
                           "and an ellipsoidal cloud over the forest (the sphere's 1 - r^2 "
                           "profile in the ellipsoid's metric), over a thin ground haze, lit.",
            "params": {"camera": view, "sun": {"azimuth": 230.0, "elevation": 25.0},
                       "fog_color": "#7a8593",
                       "effects": lit(scatter=0.15),
                       "layers": [
                           {"kind": "height", "density": 0.006, "falloff": 0.08, "base": 0.0},
                           # a fresh eye saw the box rise as a pillar with a vertical face, and
                           # the ellipsoid as a lens on the canopy whose lower edge cut trees in
                           # half: 9 m high at density 0.16, its opacity rose from 10% to 90%
                           # of its peak across the lower edge within 0.9 degrees (11 px at
                           # 720p; test_the_fog_ellipsoid_has_a_soft_lower_edge). Both now
                           # larger, thinner and wholly faded: the ellipsoid's edge now rises over 2.7
                           {"kind": "box", "center": (bx, 3.0, bz - 25.0), "half_size": (18.0, 9.0, 48.0),
                            "yaw": -12.0, "density": 0.04, "edge_fade": 1.0},
                           {"kind": "ellipsoid", "center": (fx, fy + 6.0, fz), "radii": (45.0, 20.0, 30.0),
                            "yaw": 30.0, "pitch": 0.0, "density": 0.06}]},
        },
        "carved-clearing": {
            "title": "A clearing carved out of the fog",
            "source": "fogbank: an ellipsoid that carves the fog inside itself (Godot's negative FogVolume, Biri's subtracted objects)",
            "description": "Dense valley fog with a clearing around the house: an ellipsoid "
                           "that removes the fog inside itself, and only there, its edge faded "
                           "in steps. The house stands clear inside standing fog, with the fog "
                           "between it and the eye still in front of it.",
            # seen from above the fog, so that the clearing shows as a pocket of clear air
            # round the house in the standing fog (from 24 m up, at the fog's level, it read
            # only as a house a little less veiled than the ground beside it); the fog's
            # base at 16 m covers the house's hill (at base 0 the hilltop stood clear of it
            # whether carved or not)
            "params": {"camera": {"position": (-95.0, 55.0, 40.0), "yaw": 40.0, "pitch": -18.0, "fov": 55.0},
                       "sun": {"azimuth": 150.0, "elevation": 25.0},
                       "fog_color": "#7d8896",
                       "effects": lit(scatter=0.1),
                       "layers": [
                           {"kind": "height", "density": 0.06, "falloff": 0.09, "base": 16.0},
                           {"kind": "ellipsoid", "center": (hx, hy, hz), "radii": (30.0, 18.0, 30.0),
                            "density": 0.0, "carve": 1.0, "edge_fade": 0.5}]},
        },
        "gawron-distance": {
            "title": "Gawron & Boryczka 2018: distance fog",
            "source": "Gawron & Boryczka, Heterogeneous Fog Generated with the Effect of Light Scattering and Blur (2018): sections 3.1-3.3",
            "description": "Distance fog with noise-varied density, an orange scatter colour of "
                           "its own in the sun's direction (eqs. 5-8), its noise drifting on its own "
                           "(not with the wind) and a Gaussian blur that grows with the fog; the "
                           "sky in the fog at the horizon.",
            # the sun 17 degrees under the frame's top (pitch -3, fov 65): at pitch -13 it sat
            # 5 degrees under it, and its glow, cut by the frame, read as a pillar of light
            "params": {"camera": {**view, "pitch": -3.0, "fov": 65.0}, "fog_color": "#96938c",
                       # the sun at 10 degrees (at 9 the trees' shadows over the river bank
                       # stepped in a sawtooth); the lobe's exponent 10 keeps the orange
                       # round the sun (at 4 it washed the whole sun side peach), and its
                       # strength 0.4 and the exposure -0.5 EV below the tone map's
                       # shoulder, a soft gradient (at 0.9 and 0 EV a sixth of the frame sat
                       # at red 245-253, a flat peach column; at 1.5, 130k pixels clipped);
                       # the sky's share 0.7 of the fog's colour keeps the fog grey-blue and
                       # lets the orange read as orange over it (at 1.0, pale salmon)
                       "sun": {"azimuth": 18.0, "elevation": 10.0, "color": "#fff1d6", "intensity": 3.0},
                       "effects": {"scatter": 0.4, "scatter_exponent": 10.0, "scatter_color": "#ffb84d",
                                   "blur": "single", "blur_radius": 3.0, "tone_map": "neutral",
                                   "exposure": -0.5, "aerial_perspective": 0.7},
                       # max 0.9 and the sky's colour in the far fog: at 0.75 a quarter of
                       # the far land's green showed below the sky, a hard horizon line
                       "layers": [{"kind": "distance", "start": 10.0, "distance": 260.0, "exponent": 0.55,
                                   "low": 0.8, "high": 1.2, "max": 0.9, "noise_scale": 90.0, "wind": False,
                                   "drift": (2.0, 0.0, -1.0)}]},
        },
        "forest-shafts": {
            "title": "Shafts through the forest",
            "source": "fogbank: single scattering in height fog, the trees' shadows from the shadow map",
            "description": "Morning haze in the forest with the sun low behind the trees: each "
                           "trunk and crown casts a shadow through the fog, and the sunlit fog "
                           "between them glows forward (Henyey-Greenstein g = 0.75).",
            # the eye 11 m over the ground, inside the haze: at 20 m (27 m up) the far haze
            # lay under it and its sunlit top stood as a cream stripe along the horizon,
            # 11.5 levels over the rows 8 px above and below (a fresh eye rejected it;
            # test_no_bright_band_at_the_horizon)
            "params": {"camera": {"position": (40.0, 18.0, 20.0), "yaw": 45.0, "pitch": -4.0, "fov": 60.0},
                       "sun": {"azimuth": 45.0, "elevation": 12.0, "color": "#ffe2b8", "intensity": 3.0},
                       "fog_color": "#55606d",
                       # -1.1 EV: at 0 the forward glow round the sun sat on the tone map's
                       # shoulder, a near-clipped cream plateau (6% of the frame at 245 or
                       # more) that swallowed the sun's disc; inside the haze, at -0.8, 2.7%
                       "effects": lit(scatter=0.12, anisotropy=0.75, sky_distance=400.0, light_quality="high",
                                      exposure=-1.1),
                       "layers": [{"kind": "height", "density": 0.03, "falloff": 0.12, "base": 5.0}]},
        },
        "shaded-valley": {
            "title": "A shaded valley filled with fog",
            "source": "fogbank: single scattering in height fog, the hills' shadow from the shadow map",
            "description": "Looking up the river valley with a low sun from the east: the fog "
                           "filling the valley lies in the eastern hill's shadow, lit by the sky "
                           "alone, a dark band between the sunlit fog over the western slope and "
                           "the golden haze beyond; the trees' shadows run through it.",
            "params": {"camera": {"position": (10.0, 30.0, -150.0), "yaw": 180.0, "pitch": -10.0, "fov": 60.0},
                       "sun": {"azimuth": 110.0, "elevation": 8.0, "color": "#ffe0b0", "intensity": 3.2},
                       "fog_color": "#56616f",
                       # the "high" grid: at "medium" the low sun's grazing shadows over the
                       # valley floor (2 shadow taps a slice, a column every 16 px) read as
                       # bright blotches in the fog. Little of the sky's haze (aerial 0.15):
                       # at 0.6 the sky lit the shaded fog about as brightly as the sun lit
                       # the rest, and the valley's shade did not show. The fog thins over
                       # 10 m (falloff 0.1): at 6.7 m (0.15) its top met the sky in a razor
                       # line, the row level stepping 7.8 levels over 4 px; and -0.6 EV keeps
                       # its sunlit band off the tone map's shoulder (4% of the frame at 245
                       # or more, a near-clipped peach band)
                       "effects": lit(scatter=0.45, anisotropy=0.4, sky_distance=300.0, light_quality="high",
                                      aerial_perspective=0.15, exposure=-0.6),
                       "layers": [{"kind": "height", "density": 0.04, "falloff": 0.1, "base": 5.0}]},
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
