"""Random looks and rays drawn from the params model itself, across the whole domain its
schema allows (or a scene-scale part of it), for the accuracy tests.

Nothing here names a field: every bound, literal, list length and nested model is read
from the pydantic classes, so a new field or layer kind is drawn without a test edit.
Values are drawn from a mixture that covers the whole range, its scales and its edges:
uniform over [lo, hi], log-uniform over the positive part (tiny values to the maximum),
and the endpoints themselves. Model validators (c0 >= sum |amp|, P >= 0, ...) are
honoured by rejection: a draw they refuse is drawn again.
"""

from __future__ import annotations

import contextlib
import math
import types
import typing
from typing import Any, Literal, Union

import annotated_types as at
import numpy as np
from pydantic import BaseModel, ValidationError

from fogbank.model.params import LAYER_CLASSES, FogParams

from fogbank.model.fields import MAX_LAYERS, POSITION_LIMIT, RAY_LIMIT, Position

SCENE_POSITION = 500.0      # scene scale: every position within +-500 m ...
SCENE_LENGTH = 2000.0       # ... rays up to 2 km ...
SCENE_SLIDE = 1e4           # ... and wind * time up to 1e4 m
UNBOUNDED = 1e6             # magnitude drawn for a number the schema leaves unbounded


def _bounds(metadata) -> tuple[float | None, float | None, bool]:
    lo = hi = None
    open_lo = False
    for m in metadata:
        for c in (m.metadata if hasattr(m, "metadata") and not isinstance(m, at.BaseMetadata) else [m]):
            if isinstance(c, at.Ge):
                lo = c.ge
            elif isinstance(c, at.Gt):
                lo, open_lo = c.gt, True
            elif isinstance(c, at.Le):
                hi = c.le
    return lo, hi, open_lo


def _lengths(metadata) -> tuple[int, int]:
    lo, hi = 0, 8
    for m in metadata:
        for c in (m.metadata if hasattr(m, "metadata") and not isinstance(m, at.BaseMetadata) else [m]):
            if isinstance(c, at.MinLen):
                lo = c.min_length
            elif isinstance(c, at.MaxLen):
                hi = c.max_length
    return lo, hi


def draw_number(rng: np.random.Generator, lo, hi, open_lo: bool, integer: bool) -> float:
    if lo is None and hi is None:
        lo, hi = -UNBOUNDED, UNBOUNDED
    lo = -UNBOUNDED if lo is None else lo
    hi = UNBOUNDED if hi is None else hi
    if integer:
        pick = rng.random()
        if pick < 0.2:
            return int(rng.choice([lo, hi]))
        if pick < 0.6 and hi > max(lo, 1):
            return int(min(hi, max(lo, round(math.exp(rng.uniform(0, math.log(hi)))))))
        return int(rng.integers(int(lo), int(hi) + 1))
    pick = rng.random()
    if pick < 0.15:   # an edge (an open lower edge is approached, not taken)
        v = float(rng.choice([lo, hi]))
        return lo + (hi - lo) * 1e-9 if (v == lo and open_lo) else v
    if pick < 0.55 and hi > 0:   # log-uniform over the positive part, signed if it may be
        top = hi if lo >= 0 else max(hi, -lo)
        bottom = max(lo, top * 1e-7) if lo > 0 else top * 1e-7
        v = math.exp(rng.uniform(math.log(bottom), math.log(top)))
        if lo < 0 and rng.random() < 0.5:
            v = -v
        return float(min(max(v, lo), hi)) if not (open_lo and v <= lo) else float(hi)
    return float(rng.uniform(lo, hi))


def draw_value(rng, annotation, metadata, scale: str, name: str = "") -> Any:
    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)
    if origin is typing.Annotated:
        return draw_value(rng, args[0], list(metadata) + list(args[1:]), scale, name)
    if annotation == Position or (origin is tuple and args and typing.get_args(args[0])
                                  and _bounds(typing.get_args(args[0])[1:])[1] == POSITION_LIMIT):
        limit = SCENE_POSITION if scale == "scene" else POSITION_LIMIT
        return tuple(float(rng.uniform(-limit, limit)) if rng.random() < 0.8 else
                     float(rng.normal() * 20) for _ in range(3))
    if origin is Literal:
        return args[int(rng.integers(len(args)))]
    if origin in (Union, types.UnionType):
        choices = [a for a in args if a is not type(None)]
        return draw_value(rng, choices[int(rng.integers(len(choices)))], metadata, scale, name)
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return draw_model(annotation, rng, scale, as_dict=True)
    if origin is tuple:
        return tuple(draw_value(rng, a, [], scale, name) for a in args)
    if origin is list:
        lo, hi = _lengths(metadata)
        n = int(rng.integers(lo, hi + 1))
        return [draw_value(rng, args[0], [], scale, name) for _ in range(n)]
    if annotation is bool:
        return bool(rng.random() < 0.5)
    if annotation in (int, float):
        lo, hi, open_lo = _bounds(metadata)
        return draw_number(rng, lo, hi, open_lo, annotation is int)
    if annotation is str:
        return "#" + "".join(rng.choice(list("0123456789abcdef"), 6))
    raise TypeError(f"no draw for {annotation!r} ({name})")


def draw_model(cls: type[BaseModel], rng, scale: str = "domain", *, as_dict: bool = False,
               fixed: dict | None = None, tries: int = 2000):
    """A valid instance of `cls` (or its dict), every field drawn; `fixed` fields kept."""
    last = None
    for _ in range(tries):
        data = {}
        for name, f in cls.model_fields.items():
            if fixed and name in fixed:
                data[name] = fixed[name]
                continue
            data[name] = draw_value(rng, f.annotation, f.metadata, scale, name)
        try:
            obj = cls.model_validate(data)
        except ValidationError as e:
            last = e
            continue
        return obj.model_dump(mode="json") if as_dict else obj
    raise AssertionError(f"no valid {cls.__name__} in {tries} draws: {last}")


def draw_look(kind: str, rng, scale: str = "domain") -> FogParams:
    """A look with one layer of `kind`, every field of it and of the fog drawn from the
    model; the scene, camera, sun and bake keep their defaults (they do not enter T)."""
    layer = draw_model(LAYER_CLASSES[kind], rng, scale, fixed={"enabled": True, "kind": kind})
    layers = [layer.model_dump(mode="json")]
    if getattr(layer, "carve", 0) > 0:   # a carving body alone carves nothing: fog to carve goes with it
        layers.insert(0, draw_model(LAYER_CLASSES["homogeneous"], rng, scale,
                                    fixed={"enabled": True}).model_dump(mode="json"))
    fog = draw_model(FogParams, rng, scale, fixed={
        "layers": layers, "scene": "calibration",
        "camera": FogParams().camera.model_dump(mode="json"),
        "sun": FogParams().sun.model_dump(mode="json"),
        "noise": FogParams().noise.model_dump(mode="json")})
    if rng.random() < 0.5:   # half the looks without start, cutoff or max opacity
        fog = fog.model_copy(update={"effects": FogParams().effects})
    speed = float(np.linalg.norm(fog.wind.vector()))
    if scale == "domain" and rng.random() < 0.5 and speed * fog.time > 2e4:
        # half the looks keep their features within reach of the rays (a slide of up to
        # 5e7 m carries a sliding layer out of the domain, where T = 1 tells nothing)
        fog = fog.model_copy(update={"time": float(rng.uniform(0, 2e4 / speed))})
    if scale == "scene":
        speed = np.linalg.norm(fog.wind.vector())
        if speed * fog.time > SCENE_SLIDE:
            fog = fog.model_copy(update={"time": float(rng.uniform(0, SCENE_SLIDE / speed))})
        eff = fog.effects.model_copy(update={
            "start_distance": min(fog.effects.start_distance, SCENE_LENGTH)})
        fog = fog.model_copy(update={"effects": eff})
    return fog


def feature_points(layer) -> list[np.ndarray]:
    """Every position-typed field of a layer (a centre, an emitter): rays are aimed there."""
    pts = []
    for name, f in type(layer).model_fields.items():
        if f.annotation == Position:
            pts.append(np.asarray(getattr(layer, name), dtype=np.float64))
    return pts


def unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def draw_rays(fog: FogParams, rng, n: int, scale: str = "domain", extra=()):
    """n rays (origin, unit direction, length): random ones, axis-aligned ones and ones aimed
    near the layers' feature points (slid by the wind where the layer moves with it) or
    near the `extra` points (particles where they are)."""
    limit = SCENE_POSITION if scale == "scene" else POSITION_LIMIT
    longest = SCENE_LENGTH if scale == "scene" else RAY_LIMIT
    O = rng.uniform(-limit, limit, (n, 3))
    near = rng.random(n) < 0.4
    O[near] = rng.normal(size=(near.sum(), 3)) * rng.choice([1.0, 30.0, 300.0], (near.sum(), 1))
    O = np.clip(O, -limit, limit)
    W = unit(rng.normal(size=(n, 3)))
    axes = unit(np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, -1, 0], [-1, 0, 0], [0, 0, -1]], float))
    W[: min(3, n)] = axes[rng.integers(0, 6, min(3, n))]
    D = np.exp(rng.uniform(np.log(1e-3), np.log(longest), n))
    D[rng.random(n) < 0.05] = 0.0
    targets = []
    for layer in fog.layers:
        for p in feature_points(layer):
            targets.append(p + (fog.wind.vector() * fog.time if layer.wind else 0.0))
    targets += [np.asarray(p, dtype=np.float64) for p in extra]
    for i in range(n):
        if targets and rng.random() < 0.7:
            p = targets[int(rng.integers(len(targets)))]
            miss = unit(rng.normal(size=3)) * math.exp(rng.uniform(math.log(1e-4), math.log(1e3)))
            if rng.random() < 0.3:
                miss = miss * 0.0          # straight through the feature
            aim = p + miss - O[i]
            if np.linalg.norm(aim) > 0:
                W[i] = unit(aim)
                reach = np.linalg.norm(aim)
                D[i] = min(longest, reach * float(rng.choice([0.5, 1.0, 2.0, 10.0])))
    return O, W, D


@contextlib.contextmanager
def _long_text():
    """Draws whose readable query is as long as the model allows: every list at its
    longest, every number given a 17-digit text (its magnitude kept, so the model's
    validators refuse a draw no more often than any other)."""
    global draw_number, _lengths
    number, lengths = draw_number, _lengths

    def long_number(rng, lo, hi, open_lo, integer):
        v = number(rng, lo, hi, open_lo, integer)
        if integer or not v:
            return v
        for w in (v * (1 + 2 ** -40), v * (1 - 2 ** -40)):
            if (lo is None or w > lo or (w == lo and not open_lo)) and (hi is None or w <= hi):
                return w
        return v
    draw_number, _lengths = long_number, (lambda metadata: (lengths(metadata)[1],) * 2)
    try:
        yield
    finally:
        draw_number, _lengths = number, lengths


def long_look(rng, min_chars: int | None = None, cls: type[FogParams] = FogParams, scale: str = "scene",
              enabled: int | None = None):
    """A look with a long readable query: layers of the kind whose layer reads longest,
    with long text (see _long_text), added until the query is `min_chars` long, the rest
    the model's defaults; only the first `enabled` layers on (None: all; a test of links
    need not pay the seconds a fog program of many layers takes to compile). With
    `min_chars` None: MAX_LAYERS such layers and every other field drawn too, which is the
    longest look the schema allows, near enough."""
    from fogbank.model.urlstate import encode

    def text(fog) -> int:
        return len(encode(fog))
    with _long_text():
        def layer(kind):
            return draw_model(LAYER_CLASSES[kind], rng, scale, as_dict=True, fixed={"kind": kind, "enabled": True})
        kind = max(LAYER_CLASSES, key=lambda k: max(text(cls.model_validate({"layers": [layer(k)]}))
                                                     for _ in range(8)))

        def best():
            return max((layer(kind) for _ in range(8)), key=lambda l: text(cls.model_validate({"layers": [l]})))
        if min_chars is None:
            return draw_model(cls, rng, scale, fixed={"layers": [best() for _ in range(MAX_LAYERS)]})
        layers: list[dict] = []
        while len(layers) < MAX_LAYERS:
            layers.append(best())
            if enabled is not None:
                layers[-1]["enabled"] = len(layers) <= enabled
            fog = cls.model_validate({"layers": layers})
            if text(fog) >= min_chars:
                return fog
    raise AssertionError(f"no look of {min_chars} characters with {MAX_LAYERS} layers")
