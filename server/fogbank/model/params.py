"""The params model: the single source of truth for a look.

REST bodies, the JSON Schema the page builds its sliders from, WebSocket messages and
the URL codec all derive from these classes. A new parameter is one field here (or, for
a fog layer, in its kind's module: the layer union is built from the kinds registry).

Units: lengths in scene units (metres), angles in degrees, time in seconds, densities
in 1/m (optical depth per metre), colours as sRGB hex "#rrggbb".
"""

from __future__ import annotations

import math
from typing import Annotated, Literal, Union

import numpy as np
from pydantic import ConfigDict, Field, model_validator

from fogbank.kinds import KINDS
from fogbank.model.fields import MAX_LAYERS, MAX_PARTICLES, POSITION_LIMIT, Bool, Color, Int, Position, Strict, num
from fogbank.scene.bounds import CAMERA_BOUNDS, camera_bounds_schema


MAX_PIXELS = 16_000_000

# The page's panel sections, as an artist looks for things, in the order shown. Each
# field names its section with `group` (an object's fields inherit its group).
PANEL_GROUPS = ("Fog", "Layers", "Light", "Wind", "Distance and sky", "Blur", "Camera",
                "Scene and quality")


def grouped(name: str) -> dict:
    if name not in PANEL_GROUPS:
        raise ValueError(f"panel group {name!r}: one of {PANEL_GROUPS}")
    return {"group": name}


# ---------------------------------------------------------------- scene and camera


class Camera(Strict):
    position: Position = Field((-60.0, 22.0, 95.0), description=f"eye position, m (each axis within +-{POSITION_LIMIT:g})")
    yaw: float = num(-35.0, -360, 360, 0.5, "deg", "heading; 0 looks along -z, positive turns right")
    pitch: float = num(-8.0, -89, 89, 0.5, "deg", "up/down; positive looks up")
    fov: float = num(55.0, 10, 120, 1, "deg", "vertical field of view")


class Wind(Strict):
    direction: float = num(70.0, 0, 360, 1, "deg", "where the wind blows to; 0 = -z, 90 = +x")
    speed: float = num(1.5, 0, 50, 0.1, "m/s", "wind speed")

    def vector(self) -> np.ndarray:
        a = math.radians(self.direction)
        return np.array([math.sin(a), 0.0, -math.cos(a)]) * self.speed


class Sun(Strict):
    azimuth: float = num(120.0, 0, 360, 1, "deg", "compass direction toward the sun; 0 = -z, 90 = +x")
    elevation: float = num(25.0, -10, 90, 0.5, "deg", "height of the sun above the horizon")
    color: Color = "#fff1d6"
    intensity: float = num(3.0, 0, 20, 0.1, "", "sun radiance scale")

    def direction(self) -> np.ndarray:
        """Unit vector toward the sun."""
        a, e = math.radians(self.azimuth), math.radians(self.elevation)
        return np.array([math.sin(a) * math.cos(e), math.sin(e), -math.cos(a) * math.cos(e)])


# ---------------------------------------------------------------- fog layers

# every registered kind's model, told apart by `kind` (kinds/__init__.py)
LAYER_CLASSES = {name: k.model for name, k in KINDS.items()}
Layer = Annotated[Union[tuple(LAYER_CLASSES.values())], Field(discriminator="kind")]


# ---------------------------------------------------------------- effects


class NoiseBake(Strict):
    """The one tiling noise texture that noise and distance layers sample."""
    size: Int = Field(64, ge=8, le=128, description="texels per side (a power of two is best)")
    octaves: Int = Field(4, ge=1, le=6, description="fractal octaves")
    blur: Int = Field(2, ge=0, le=8, description="binomial blur order (0 = none)")
    seed: Int = Field(7, ge=0, le=2**31 - 1)


class Effects(Strict):
    start_distance: float = num(0.0, 0, 10000, 1, "m", "no fog nearer than this", group="Distance and sky")
    cutoff_distance: float = num(0.0, 0, 100000, 10, "m",
                                 "points beyond this get no fog or all fog, by cutoff_mode (0 = off)", group="Distance and sky")
    cutoff_mode: Literal["clear", "fog"] = Field(
        "clear", json_schema_extra=grouped("Distance and sky"), description="beyond cutoff_distance: 'clear' shows points unfogged (Unreal's "
                             "meaning, for skies), 'fog' hides them in the fog colour (Biri 2002, 4.2)")
    max_opacity: float = num(1.0, 0, 1, 0.01, "", "fog never hides more than this", group="Distance and sky")
    sky_distance: float = num(800.0, 1, 100000, 10, "m", "how far a sky pixel's ray runs", group="Distance and sky")
    sky_affect: float = num(1.0, 0, 1, 0.01, "", "how much of its fog the sky shows (Godot's sky "
                            "affect): 1 = all of it, 0 = an unfogged sky; its T becomes "
                            "1 - sky_affect (1 - T)", group="Distance and sky")
    aerial_perspective: float = num(0.0, 0, 1, 0.01, "", "the sky in the fog (Godot's aerial perspective): "
                                    "how much the fog's colour is the sky's in the direction of view instead of "
                                    "fog_color, the sky's mean near the eye, its colour toward the horizon at the "
                                    "sky distance (distant land fades into the sky; no horizon line)",
                                    group="Distance and sky")
    scatter: float = num(0.6, 0, 10, 0.005, "", "sun in-scattering strength (Gawron 3.2)", group="Light")
    scatter_exponent: float = num(8.0, 0.1, 256, 0.1, "", "in-scattering falloff", group="Light")
    scatter_color: Color = Field("#ffffff", json_schema_extra=grouped("Light"), description="Gawron's ScatterColor, as a tint of the "
                                 "sunlight: in-scattered light = sun colour x intensity x this x scatter")
    scatter_start: float = num(0.0, 0, 10000, 10, "m", "Gawron eq. 5: ScatterStartDist, added to the "
                               "view vector (each component) before it is normalised", group="Light")
    phase: Literal["gawron", "henyey-greenstein"] = Field(
        "gawron", json_schema_extra=grouped("Light"), description="in-scattering lobe: Gawron's max(0, cos)^scatter_exponent, or the "
                              "Henyey-Greenstein phase function with anisotropy g (times 4 pi: 1 "
                              "in every direction when g = 0)")
    anisotropy: float = num(0.6, -0.95, 0.95, 0.01, "", "Henyey-Greenstein g: 0 scatters evenly, "
                            "> 0 forward (a glow round the sun), < 0 back toward it", group="Light")
    lit: Bool = Field(
        False, json_schema_extra=grouped("Light"), description="lit fog (single scattering): the sunlight that "
        "reaches each point of the fog is dimmed by the fog between it and the sun (the layers' closed forms), "
        "so dense fog shades itself and fog behind fog is darker; fog_color is then the fog's colour in shade "
        "(lit by the sky). Off: the papers' fog, lit everywhere alike")
    shafts: float = num(0.0, 0, 1, 0.05, "", "shadows in the fog (light shafts): how much the scene's "
                        "shadows, from the shadow map, take from the sunlight the fog scatters "
                        "(0 = none, 1 = all of it)", group="Light")
    light_quality: Literal["low", "medium", "high"] = Field(
        "medium", json_schema_extra=grouped("Light"), description="the light grid of lit fog and shafts: "
        "one view ray every 32, 16 or 8 px, cut into 12, 16 or 32 slices, with 2, 2 or 8 shadow-map samples "
        "a slice (previews take 'low'); the fog's transmittance is exact at every quality")
    sun_through_fog: Bool = Field(
        False, json_schema_extra=grouped("Light"), description="dim the sunlight on each surface by the fog between it and the sun: "
                           "the density layers' closed forms along the sun's direction for "
                           "sky_distance metres (shadows soften under dense fog)")
    exposure: float = num(0.0, -10, 10, 0.1, "EV", "exposure in stops: the linear image is scaled by 2^EV "
                          "before the tone map", group="Light")
    tone_map: Literal["none", "neutral", "agx"] = Field(
        "none", json_schema_extra=grouped("Light"), description="how linear HDR light becomes the 8-bit image: "
        "'none' clips at 1 (the papers' output), 'neutral' the Khronos PBR Neutral curve (colours kept up to "
        "0.76, highlights rolled off toward white without a hue shift), 'agx' Troy Sobotka's AgX (Blender 4's "
        "filmic default: a gentle S-curve that desaturates toward white)")
    blur: Literal["off", "single", "separate"] = Field(
        "off", json_schema_extra=grouped("Blur"), description="fog blur: off, fused with the composite, or separate passes")
    blur_radius: float = num(3.0, 0, 16, 0.25, "px", "Gaussian sigma at full fog (at 720 px high)", group="Blur")
    blur_exponent: float = num(1.0, 0.1, 8, 0.1, "", "sigma = radius * (1 - T)^exponent", group="Blur")
    fog_scale: Literal[1, 2, 4] = Field(1, json_schema_extra=grouped("Scene and quality"),
                                        description="fog computed at 1/1, 1/2 or 1/4 size: "
                                                    "faster, softer at fog edges")


class FogParams(Strict):
    """A whole look: scene, camera, time, wind, sun, fog colour and layers."""
    # the page's sections and each scene's camera bounds go with the schema
    model_config = ConfigDict(**Strict.model_config, json_schema_extra={
        "groups": list(PANEL_GROUPS), "camera_bounds": camera_bounds_schema()})
    scene: Literal[tuple(CAMERA_BOUNDS)] = Field(  # type: ignore[valid-type]
        "countryside", json_schema_extra=grouped("Scene and quality"),
        description="the land under the fog: 'countryside', or 'calibration' (a flat unlit "
                    "ground and four boxes, for measuring)")
    camera: Camera = Field(default_factory=Camera, json_schema_extra=grouped("Camera"))
    time: float = num(0.0, 0, 1e6, 0.1, "s", "simulation time")
    wind: Wind = Field(default_factory=Wind, json_schema_extra=grouped("Wind"))
    sun: Sun = Field(default_factory=Sun, json_schema_extra=grouped("Light"))
    fog_color: Color = Field("#c5ccd6", json_schema_extra=grouped("Fog"),
                             description="the colour the fog hides things in")
    density: float = num(1.0, 0, 20, 0.01, "", "global density: T becomes T^density",
                         group="Fog", title="global density")
    layers: list[Layer] = Field(default_factory=list, max_length=MAX_LAYERS,
                                json_schema_extra=grouped("Layers"),
                                description="the fog's layers: their optical depths add up")
    effects: Effects = Field(default_factory=Effects)
    noise: NoiseBake = Field(default_factory=NoiseBake, json_schema_extra=grouped("Scene and quality"),
                             description="the baked noise texture that noise and distance "
                                         "layers sample")

    @model_validator(mode="after")
    def _particle_budget(self) -> "FogParams":
        n = sum(l.count for l in self.layers if l.kind == "particles")
        if n > MAX_PARTICLES:
            raise ValueError(f"{n} particles in all; at most {MAX_PARTICLES} are allowed")
        return self


class StillParams(FogParams):
    """A still: a look plus its size."""
    width: Int = Field(1280, ge=1, le=4096, description="px")
    height: Int = Field(720, ge=1, le=4096, description="px")

    @model_validator(mode="after")
    def _pixels(self) -> "StillParams":
        if self.width * self.height > MAX_PIXELS:
            raise ValueError(f"{self.width}x{self.height} = {self.width * self.height} pixels is "
                             f"over 16 Mpx (at most {MAX_PIXELS} pixels in all)")
        return self

    def fog(self) -> FogParams:
        return FogParams.model_validate(self.model_dump(exclude={"width", "height"}))
