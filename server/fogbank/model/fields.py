"""The field types every part of the params model shares: bounded numbers with their slider
step and unit, colours, positions and directions, and the base of every fog layer.

Units: lengths in scene units (metres), angles in degrees, time in seconds, densities
in 1/m (optical depth per metre), colours as sRGB hex "#rrggbb".
"""

from __future__ import annotations

import re
from typing import Annotated, Any, ClassVar

from pydantic import AfterValidator, BeforeValidator, BaseModel, ConfigDict, Field

MAX_LAYERS = 16
MAX_PARTICLES = 1024   # over all particle layers of a look (one texture row)


# A slider is logarithmic when its range spans this many steps or more from a bound of
# zero or above: 2% of a linear 0-10 slider is 0.2, most of a density's useful range.
LOG_SPAN = 1000


def num(default: float, lo: float, hi: float, step: float, unit: str = "", desc: str = "",
        *, gt: bool = False, title: str | None = None, scale: str | None = None,
        group: str | None = None) -> Any:
    """A bounded number with the slider step, unit and scale the page shows.

    `scale` is "log" or "linear": by default "log" for a range of LOG_SPAN steps or more
    that starts at zero or above, so the page and the schema state one scale. `title` is
    the label (words, where the paper's symbol would mean nothing to a reader); `group`
    the panel section it sits in when not its parent's."""
    bound = {"gt": lo} if gt else {"ge": lo}
    if scale is None:
        scale = "log" if lo >= 0 and (hi - lo) / step >= LOG_SPAN else "linear"
    if scale not in ("log", "linear"):
        raise ValueError(f"scale {scale!r}: 'log' or 'linear'")
    extra: dict[str, Any] = {"step": step, "unit": unit, "scale": scale}
    if group:
        extra["group"] = group
    # strict: a JSON number only (an int is fine), never a boolean or a numeric string
    return Field(default, le=hi, description=desc, strict=True, title=title, **bound,
                 json_schema_extra=extra)


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
# a layer's own drift, m/s per axis (the noise kinds: Gawron 3.3 shifts the noise's
# coordinates in time by a user value, apart from the wind)
DriftSpeed = Annotated[float, Field(strict=True, ge=-20.0, le=20.0)]
Drift = tuple[DriftSpeed, DriftSpeed, DriftSpeed]


def drift_field():
    return Field((0.0, 0.0, 0.0), description="the noise's own motion, m/s, added to the wind's "
                                              "(Gawron 3.3: the noise coordinates shift in time)")
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


# ---------------------------------------------------------------- fog layers


def _kind_required(schema: dict[str, Any], cls: type) -> None:
    """`kind` picks a layer's class, so the JSON Schema requires it (a layer without one
    matches no branch of the union). A kind's help (its source, a sentence on what it
    does and its formula, as LaTeX and as MathML that browsers draw without a library)
    goes with it, so the page shows what the model states."""
    if "kind" in schema.get("properties", {}):
        schema["required"] = sorted(set(schema.get("required", [])) | {"kind"})
    if getattr(cls, "source", ""):
        schema["source"] = cls.source
        schema["summary"] = cls.summary
        schema["formula"] = cls.formula
        schema["formula_mathml"] = mathml(cls.formula)


def mathml(latex: str) -> str:
    """LaTeX -> MathML (display), drawn natively by the browser (no CDN, no fonts)."""
    from latex2mathml.converter import convert
    return convert(latex, display="block")


def with_rules(*rules: dict[str, Any]):
    """A layer kind's json_schema_extra: LayerBase's (`kind` required, the kind's help) and
    its validator's cross-field rules stated for the page (x-rules: static/controls.js
    keepRules). A kind's own json_schema_extra replaces LayerBase's; this keeps both."""
    def extra(schema: dict[str, Any], cls: type) -> None:
        _kind_required(schema, cls)
        schema["x-rules"] = [dict(r) for r in rules]
    return extra


class LayerBase(Strict):
    """A fog layer. Each kind's class states `source` (the paper and section), `summary`
    (what it does, in a sentence a newcomer reads) and `formula` (LaTeX)."""
    model_config = ConfigDict(**Strict.model_config, json_schema_extra=_kind_required)
    source: ClassVar[str] = ""
    summary: ClassVar[str] = ""
    formula: ClassVar[str] = ""
    enabled: Bool = Field(True, description="a disabled layer is kept but not drawn")
    wind: Bool = Field(False, description="wind-sensitive: the density slides with wind * time")
