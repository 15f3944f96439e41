"""schemathesis hooks for test_fuzz_api (loaded with SCHEMATHESIS_HOOKS).

Positive data acceptance holds the server to: every request valid by the OpenAPI
document and by the rules its descriptions state (openapi.RULES) is accepted. Those rules
are re-implemented here, independently of the server's validators (a grid check of
P(u) >= 0 rather than the server's root finding), and generated positive cases that break
them are left out. Frame sizes are clamped to 256 px a side (still within the schema), and
a still that leaves its size out gets 256x144 instead of the default 1280x720, so that the
run renders many looks in little time; the cost budget and the default size are tested
elsewhere."""

from __future__ import annotations

import numpy as np
import schemathesis

MAX_SIDE = 256


def _poly_ok(layer: dict) -> bool:
    c = np.asarray(layer.get("coeffs", [0.8, -1.0, 0.0, 0.0, 1.0]), dtype=np.float64)
    C = float(layer.get("half_width", 1.0))
    u = np.linspace(-C, C, 20001)
    v = np.polynomial.polynomial.polyval(u, c)
    scale = max(1.0, float(np.abs(c).max()) * max(1.0, C) ** (len(c) - 1))
    if layer.get("mode", "mirror") == "repeat":   # the border values match, by Horner at +-C
        left, right = (float(np.polyval(c[::-1], x)) for x in (-C, C))
        if abs(left - right) > 1e-9 * float(np.sum(np.abs(c) * C ** np.arange(len(c)))) * 0.99:
            return False
    return bool(v.min() >= -1e-6 * scale)


def _look_ok(look) -> bool:
    if not isinstance(look, dict):
        return True
    layers = look.get("layers", [])
    if not isinstance(layers, list):
        return True
    total = 0
    for layer in layers:
        if not isinstance(layer, dict):
            return True
        kind = layer.get("kind")
        try:
            if kind == "cosine":
                terms = layer.get("terms", [{"amp": 0.5}])
                if float(layer.get("c0", 1.0)) < sum(abs(float(t.get("amp", 0.5))) for t in terms):
                    return False
            elif kind == "polynomial" and not _poly_ok(layer):
                return False
            elif kind == "particles":
                if int(layer.get("life_min", 64)) > int(layer.get("life_max", 128)):
                    return False
                total += int(layer.get("count", 120))
            elif kind == "potential" and layer.get("shape") == "line":
                # np.hypot of the 3 values raised a TypeError, which kept the cases this meant to drop
                if float(np.linalg.norm(np.asarray(layer.get("direction", [0, 1, 0]), dtype=np.float64))) < 1e-6:
                    return False
        except (TypeError, ValueError, AttributeError):
            return True   # not a valid look anyway: negative data, not filtered
    return total <= 1024


def _positive(case) -> bool:
    meta = getattr(case, "meta", None)
    return meta is None or meta.generation.mode.is_positive


@schemathesis.hook
def filter_case(ctx, case) -> bool:
    if not _positive(case):
        return True
    body = case.body if isinstance(case.body, dict) else None
    if body is not None and "rays" in body:
        rays = body.get("rays")
        if isinstance(rays, list) and len({r.get("time", 0) for r in rays if isinstance(r, dict)}) > 16:
            return False
        return _look_ok(body.get("params", {}))
    if body is not None and "kind" in body:   # /api/layers/suggest: a kind and a look
        return _look_ok(body.get("params", {}))
    if body is not None and "x" in body:      # /api/plot/ray: a pixel inside the view, a look
        try:
            inside = float(body["x"]) < float(body["width"]) and float(body["y"]) < float(body["height"])
        except (KeyError, TypeError, ValueError):
            return True
        return inside and _look_ok(body.get("params", {}))
    if body is not None and "layer" in body:  # /api/layers/profile: a valid layer, points to match
        layer, points = body.get("layer"), body.get("points")
        if not isinstance(layer, dict) or not _look_ok({"layers": [layer]}):
            return False
        if points is None:
            return True
        n = (len(layer.get("coeffs", [0.8, -1.0, 0.0, 0.0, 1.0])) if layer.get("kind") == "polynomial"
             else 2 * (len(layer.get("terms", [{}])) + 1))
        return isinstance(points, list) and len(points) == n
    return _look_ok(body)


@schemathesis.hook
def map_case(ctx, case):
    if not _positive(case):   # negative data keeps its out-of-schema sizes
        return case
    if case.operation.path.startswith("/api/still"):   # the size is in the GET's query, the POST's body
        holder = case.query if case.operation.method.upper() == "GET" else case.body
        if isinstance(holder, dict):
            holder.setdefault("width", MAX_SIDE)
            holder.setdefault("height", MAX_SIDE * 9 // 16)
    for holder in (case.query, case.body):
        if isinstance(holder, dict):
            for k, at in (("width", "x"), ("height", "y")):
                v = holder.get(k)
                if isinstance(v, (int, float)) and not isinstance(v, bool) and v > MAX_SIDE:
                    holder[k] = type(v)(MAX_SIDE)
                    p = holder.get(at)   # a pixel of the view (/api/plot/ray) scales with it
                    if isinstance(p, (int, float)) and not isinstance(p, bool):
                        holder[at] = p * MAX_SIDE / v
    return case
