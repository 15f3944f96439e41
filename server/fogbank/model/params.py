"""The params model: the single source of truth for a look.

REST bodies, the JSON Schema the page builds its sliders from, WebSocket messages and
the URL codec all derive from these classes. A new fog parameter is one field here.

Units: lengths in scene units (metres), angles in degrees, time in seconds, densities
in 1/m (optical depth per metre), colours as sRGB hex "#rrggbb".
"""

from __future__ import annotations

import math
import re
from typing import Annotated, Any, Literal, Union

import numpy as np
from pydantic import (
    AfterValidator,
    BeforeValidator,
    BaseModel,
    ConfigDict,
    Field,
    model_validator,
)

MAX_LAYERS = 16
MAX_PARTICLES = 1024
MAX_COSINE_TERMS = 8
MAX_POLY_COEFFS = 8
MAX_PIXELS = 16_000_000


def num(default: float, lo: float, hi: float, step: float, unit: str = "", desc: str = "",
        *, gt: bool = False) -> Any:
    """A bounded number with the slider step and unit the page shows."""
    bound = {"gt": lo} if gt else {"ge": lo}
    # strict: a JSON number only (an int is fine), never a boolean or a numeric string
    return Field(default, le=hi, description=desc, strict=True, **bound,
                 json_schema_extra={"step": step, "unit": unit})


COLOR_PATTERN = r"^#?[0-9a-fA-F]{6}$"


def _hex_color(v: str) -> str:
    if not re.fullmatch(COLOR_PATTERN, v):
        raise ValueError("a colour is 6 hex digits, '#rrggbb' (the '#' may be left out)")
    return "#" + v.lstrip("#").lower()


# the pattern states exactly what the validator accepts (the JSON Schema and the model agree)
Color = Annotated[str, AfterValidator(_hex_color),
                  Field(json_schema_extra={"format": "color", "pattern": COLOR_PATTERN})]
Num = Annotated[float, Field(strict=True)]   # a number: not a boolean, not a string


def _integral(v: Any) -> Any:
    """JSON Schema counts 177.0 as an integer: accept a float with no fraction as its
    int. Anything else (177.5, true, "177") is left for the strict int check to refuse."""
    if isinstance(v, float) and v.is_integer():
        return int(v)
    return v


Int = Annotated[int, BeforeValidator(_integral), Field(strict=True)]
Bool = Annotated[bool, Field(strict=True)]     # true or false: not 0/1, not "yes"
# The domain where the accuracy contract holds (docs/accuracy.md): every position in the
# scene (eye, ray origin, centre, emitter) within +-POSITION_LIMIT m on each axis, every
# ray at most RAY_LIMIT m long. Beyond them float32 cannot place a point to the
# millimetre the contract needs, so the schema refuses them (422 naming the field).
POSITION_LIMIT = 10_000.0
RAY_LIMIT = 100_000.0
Coord = Annotated[float, Field(strict=True, ge=-POSITION_LIMIT, le=POSITION_LIMIT)]
Position = tuple[Coord, Coord, Coord]
# a direction or a wave vector: any non-degenerate finite vector, bounded so that its
# float32 square (for normalising) stays finite
Comp = Annotated[float, Field(strict=True, ge=-1e6, le=1e6)]
Direction = tuple[Comp, Comp, Comp]
Wave = Annotated[float, Field(strict=True, ge=-1000, le=1000)]   # a wave vector's component


def srgb_to_linear(c: str) -> tuple[float, float, float]:
    """'#rrggbb' (sRGB) to linear-light RGB in [0, 1] (IEC 61966-2-1)."""
    out = []
    for i in (1, 3, 5):
        v = int(c[i:i + 2], 16) / 255.0
        out.append(v / 12.92 if v <= 0.04045 else ((v + 0.055) / 1.055) ** 2.4)
    return tuple(out)  # type: ignore[return-value]


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, validate_assignment=False)


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


def _kind_required(schema: dict[str, Any], cls: type) -> None:
    """`kind` picks a layer's class, so the JSON Schema requires it (a layer without one
    matches no branch of the union)."""
    if "kind" in schema.get("properties", {}):
        schema["required"] = sorted(set(schema.get("required", [])) | {"kind"})


class LayerBase(Strict):
    model_config = ConfigDict(**Strict.model_config, json_schema_extra=_kind_required)
    enabled: Bool = Field(True, description="a disabled layer is kept but not drawn")
    wind: Bool = Field(False, description="wind-sensitive: the density slides with wind * time")


class Homogeneous(LayerBase):
    """OpenGL's exponential fog: constant density."""
    kind: Literal["homogeneous"] = "homogeneous"
    density: float = num(0.01, 0, 10, 0.0005, "1/m", "extinction coefficient")


class Height(LayerBase):
    """Unreal/Filament height fog: rho * exp(-falloff * (y - base))."""
    kind: Literal["height"] = "height"
    density: float = num(0.03, 0, 10, 0.0005, "1/m", "extinction at the base height")
    falloff: float = num(0.15, 0, 5, 0.005, "1/m", "how fast density drops with height")
    base: float = num(0.0, -200, 200, 0.5, "m", "height where density equals `density`")


class CosineTerm(Strict):
    amp: float = num(0.5, -10, 10, 0.01, "", "amplitude c_i")
    k: tuple[Wave, Wave, Wave] = Field((0.0, 1.0, 0.0), description="wave vector, rad per function unit")
    phase: float = num(0.0, -1000, 1000, 0.01, "rad", "phase phi_i")


class Cosine(LayerBase):
    """Biri 3.2.1: density * (c0 + sum c_i cos(k_i . x / scale + phi_i))."""
    kind: Literal["cosine"] = "cosine"
    density: float = num(0.01, 0, 10, 0.0005, "1/m", "overall weight")
    c0: float = num(1.0, 0, 100, 0.01, "", "constant term")
    terms: list[CosineTerm] = Field(default_factory=lambda: [CosineTerm()],
                                    max_length=MAX_COSINE_TERMS)
    scale: float = num(20.0, 0.01, 10000, 0.5, "m", "scene metres per function unit", gt=True)

    @model_validator(mode="after")
    def _nonnegative(self) -> "Cosine":
        s = sum(abs(t.amp) for t in self.terms)
        if self.c0 < s:
            raise ValueError(f"c0 = {self.c0} must be >= the sum of |amp| = {s:g} "
                             "(Biri 3.2.1) so that the density stays >= 0")
        return self


def poly_min(coeffs: list[float], lo: float, hi: float) -> float:
    """Minimum of sum coeffs[i] u^i on [lo, hi] (endpoints and real critical points)."""
    c = np.asarray(coeffs, dtype=np.float64)
    cands = [lo, hi]
    if len(c) > 2:
        d = np.polynomial.polynomial.polyder(c)
        if np.any(d != 0):
            for r in np.polynomial.polynomial.polyroots(np.trim_zeros(d, "b")):
                if abs(r.imag) < 1e-9 and lo <= r.real <= hi:
                    cands.append(float(r.real))
    return float(min(np.polynomial.polynomial.polyval(cands, c)))


class Polynomial(LayerBase):
    """Biri 3.2.2: density * P(u), u = axis . x + offset, on [-C, C], tiled or zero outside."""
    kind: Literal["polynomial"] = "polynomial"
    density: float = num(0.02, 0, 10, 0.0005, "1/m", "weight c_i")
    coeffs: list[Num] = Field([0.8, -1.0, 0.0, 0.0, 1.0], min_length=1,
                                max_length=MAX_POLY_COEFFS,
                                description="P(u) = sum coeffs[i] u^i (ascending powers)")
    axis: tuple[Wave, Wave, Wave] = Field((1.0 / 60.0, 0.0, 0.0), description="u = axis . x + offset, 1/m")
    offset: float = num(0.0, -1000, 1000, 0.01, "", "added to u")
    half_width: float = num(1.0, 1e-3, 1000, 0.01, "", "C: P is defined on [-C, C]", gt=True)
    mode: Literal["repeat", "zero"] = Field("repeat", description="outside [-C, C]: tile or zero")

    @model_validator(mode="after")
    def _nonnegative(self) -> "Polynomial":
        for i, c in enumerate(self.coeffs):
            if not math.isfinite(c) or abs(c) > 1e6:
                raise ValueError(f"coeffs[{i}] must be finite with |c| <= 1e6")
        m = poly_min(self.coeffs, -self.half_width, self.half_width)
        if m < -1e-9:
            raise ValueError(f"P(u) reaches {m:.4g} < 0 on [-C, C] = [-{self.half_width:g}, "
                             f"{self.half_width:g}]; a density must be >= 0 (Biri 3.2.2)")
        return self


class Potential(LayerBase):
    """Biri 3.2.3, eq. 9: strength / (c + e r^2), r the distance to a point or a line."""
    kind: Literal["potential"] = "potential"
    shape: Literal["point", "line"] = "point"
    center: Position = Field((0.0, 5.0, 0.0), description="the point, or a point on the line, m")
    direction: Direction = Field((0.0, 1.0, 0.0), description="the line's direction (unused for a point)")
    strength: float = num(1.0, 0, 1000, 0.01, "1/m", "numerator a")
    c: float = num(20.0, 1e-3, 1e6, 0.1, "", "constant term c > 0", gt=True)
    e: float = num(1.0, 1e-6, 1e3, 0.01, "1/m^2", "r^2 weight e > 0", gt=True)

    @model_validator(mode="after")
    def _line_direction(self) -> "Potential":
        if self.shape == "line" and math.hypot(*self.direction) < 1e-6:
            raise ValueError("a line potential needs a non-zero direction")
        return self


class Sphere(LayerBase):
    """Quilez: density * max(0, 1 - |x - center|^2 / radius^2)."""
    kind: Literal["sphere"] = "sphere"
    center: Position = Field((0.0, 8.0, 0.0), description="m")
    radius: float = num(15.0, 0.01, 1000, 0.1, "m", "", gt=True)
    density: float = num(0.1, 0, 10, 0.001, "1/m", "density at the centre")


class Particles(LayerBase):
    """Fischer: a few free-floating particles; T = prod (1 - alpha s_j clamp(1 - dist_j/R, 0, 1))."""
    kind: Literal["particles"] = "particles"
    count: Int = Field(120, ge=1, le=MAX_PARTICLES, description="particles alive at once (slots)")
    emitter: Position = Field((10.0, 2.0, 0.0), description="where particles are born, m")
    direction: Direction = Field((0.0, 1.0, 0.0), description="mean launch direction")
    spread: float = num(25.0, 0, 180, 1, "deg", "cone half-angle around direction")
    speed: float = num(1.5, 0, 50, 0.1, "m/s", "launch speed")
    life_min: Int = Field(64, ge=1, le=1000, description="shortest life, steps")
    life_max: Int = Field(128, ge=1, le=1000, description="longest life, steps")
    step: float = num(0.1, 0.005, 10, 0.005, "s", "simulation step", gt=True)
    radius: float = num(4.0, 0.01, 100, 0.1, "m", "R_j", gt=True)
    alpha: float = num(0.2, 0, 1, 0.01, "", "max opacity of one particle (0.2 fog, ~1 smoke)")
    gravity: float = num(0.0, -20, 20, 0.1, "m/s^2", "upward acceleration (negative falls)")
    drag: float = num(0.5, 0, 10, 0.05, "1/s", "relaxation of velocity toward the wind")
    seed: Int = Field(1, ge=0, le=2**31 - 1, description="random seed")

    @model_validator(mode="after")
    def _life(self) -> "Particles":
        if self.life_min > self.life_max:
            raise ValueError(f"life_min = {self.life_min} must be <= life_max = {self.life_max}")
        return self


class Noise(LayerBase):
    """Perlin fog write-up: baked fractal noise n; surface T = exp(-rho d n) or volumetric."""
    kind: Literal["noise"] = "noise"
    mode: Literal["surface", "volume"] = "surface"
    density: float = num(0.02, 0, 10, 0.0005, "1/m", "rho")
    scale: float = num(60.0, 0.1, 10000, 0.5, "m", "size of one noise tile", gt=True)
    height_falloff: Bool = Field(True, description="surface mode: n * dY^2 / 2 + 0.001 (write-up)")
    falloff_scale: float = num(10.0, 0.01, 1000, 0.1, "m", "dY is measured in these units", gt=True)
    samples: Int = Field(16, ge=1, le=128, description="volume mode: most samples per ray; each ray "
                                                       "takes what its error bound needs, up to this")


class Distance(LayerBase):
    """Gawron 3.1/3.3: F = clamp(N ((d - start)/D)^e, 0, max), N = lerp(low, high, noise)."""
    kind: Literal["distance"] = "distance"
    start: float = num(0.0, 0, 10000, 1, "m", "StartDistance")
    distance: float = num(300.0, 0.1, 100000, 1, "m", "blend distance D", gt=True)
    exponent: float = num(0.55, 0.01, 10, 0.01, "", "falloff exponent", gt=True)
    low: float = num(0.9, 0, 10, 0.01, "", "density where noise = 0")
    high: float = num(1.3, 0, 10, 0.01, "", "density where noise = 1")
    max: float = num(0.6, 0, 1, 0.01, "", "largest fog amount F")
    noise_scale: float = num(80.0, 0.1, 10000, 0.5, "m", "size of one noise tile", gt=True)


Layer = Annotated[Union[Homogeneous, Height, Cosine, Polynomial, Potential, Sphere,
                        Particles, Noise, Distance], Field(discriminator="kind")]
LAYER_CLASSES = {c.model_fields["kind"].default: c for c in
                 (Homogeneous, Height, Cosine, Polynomial, Potential, Sphere, Particles,
                  Noise, Distance)}


# ---------------------------------------------------------------- effects


class NoiseBake(Strict):
    """The one tiling noise texture that noise and distance layers sample."""
    size: Int = Field(64, ge=8, le=128, description="texels per side (a power of two is best)")
    octaves: Int = Field(4, ge=1, le=6, description="fractal octaves")
    blur: Int = Field(2, ge=0, le=8, description="binomial blur order (0 = none)")
    seed: Int = Field(7, ge=0, le=2**31 - 1)


class Effects(Strict):
    start_distance: float = num(0.0, 0, 10000, 1, "m", "no fog nearer than this")
    cutoff_distance: float = num(0.0, 0, 100000, 10, "m", "no fog on points beyond this (0 = off)")
    max_opacity: float = num(1.0, 0, 1, 0.01, "", "fog never hides more than this")
    sky_distance: float = num(800.0, 1, 100000, 10, "m", "how far a sky pixel's ray runs")
    scatter: float = num(0.6, 0, 10, 0.05, "", "sun in-scattering strength (Gawron 3.2)")
    scatter_exponent: float = num(8.0, 0.1, 256, 0.5, "", "in-scattering falloff")
    blur: Literal["off", "single", "separate"] = Field(
        "off", description="fog blur: off, fused with the composite, or separate passes")
    blur_radius: float = num(3.0, 0, 16, 0.25, "px", "Gaussian sigma at full fog (at 720 px high)")
    blur_exponent: float = num(1.0, 0.1, 8, 0.1, "", "sigma = radius * (1 - T)^exponent")
    fog_scale: Literal[1, 2, 4] = Field(1, description="fog computed at 1/1, 1/2 or 1/4 size")


class FogParams(Strict):
    """A whole look: scene, camera, time, wind, sun, fog colour and layers."""
    scene: Literal["countryside", "calibration"] = "countryside"
    camera: Camera = Field(default_factory=Camera)
    time: float = num(0.0, 0, 1e6, 0.1, "s", "simulation time")
    wind: Wind = Field(default_factory=Wind)
    sun: Sun = Field(default_factory=Sun)
    fog_color: Color = "#c5ccd6"
    density: float = num(1.0, 0, 20, 0.01, "", "global density: T becomes T^density")
    layers: list[Layer] = Field(default_factory=list, max_length=MAX_LAYERS)
    effects: Effects = Field(default_factory=Effects)
    noise: NoiseBake = Field(default_factory=NoiseBake)

    @model_validator(mode="after")
    def _particle_budget(self) -> "FogParams":
        n = sum(l.count for l in self.layers if isinstance(l, Particles))
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
