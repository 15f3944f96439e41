"""The OpenAPI document, with the look described by the params model itself: the POST
still body and the transmittance params reference the model's schemas, and the GET
still's query parameters are derived from the same schema as the URL codec reads them
(dotted paths, vectors and coefficient lists comma-separated, colours without '#').

Rules across fields that JSON Schema cannot state are listed in the operations'
descriptions (RULES); the server refuses input that breaks them with a 422 naming the
field."""

from __future__ import annotations

from typing import Any

from fastapi.openapi.utils import get_openapi

from fogbank.model import presets as P
from fogbank.model.params import FogParams, StillParams
from fogbank.model.fields import MAX_PARTICLES


RULES = (
    "Rules across fields (each refused with a 422 naming the field): a cosine layer's c0 is at "
    "least the sum of |amp| of its terms (Biri 3.2.1); a polynomial layer's P(u) is >= 0 on "
    "[-half_width, half_width] (Biri 3.2.2), and in mode 'repeat' P(-half_width) = "
    "P(half_width) within 1e-9 of sum |coeffs[i]| half_width^i (a repeated tile's border "
    "must match); a particle layer's life_min <= life_max; at most "
    f"{MAX_PARTICLES} particles over all layers; a line potential has a non-zero direction; "
    "width * height <= 16,000,000. A look may also be refused (422, type 'cost') when its "
    "estimated render time or memory is beyond this server's budget; the message names what "
    "costs most.")

REF = "#/components/schemas/{model}"


def _schemas() -> dict[str, Any]:
    out: dict[str, Any] = {}
    for model in (StillParams, FogParams):
        s = model.model_json_schema(ref_template=REF)
        out.update(s.pop("$defs", {}))
        out[model.__name__] = s
    return out


def _resolve(schema: dict, defs: dict) -> dict:
    ref = schema.get("$ref")
    return defs[ref.rsplit("/", 1)[1]] if ref else schema


def query_parameters() -> list[dict[str, Any]]:
    """The GET still's query parameters: one per leaf field of StillParams, as the URL
    codec reads it. List items (layers, cosine terms) are set by index
    (`layers=2&layers.0.kind=height&layers.0.density=0.05`), which OpenAPI cannot
    declare one by one: their count is declared, the pattern described."""
    defs = StillParams.model_json_schema()["$defs"]
    root = StillParams.model_json_schema()
    params: list[dict[str, Any]] = [
        {"name": "v", "in": "query", "required": False, "description": "URL codec version",
         "schema": {"type": "integer", "enum": [1]}},
        {"name": "preset", "in": "query", "required": False,
         "description": "the look that fields not given come from (default: 'default')",
         "schema": {"type": "string", "enum": list(P.presets())}},
    ]

    def leaf(path: str, s: dict) -> dict[str, Any]:
        p: dict[str, Any] = {"name": path, "in": "query", "required": False,
                             "description": s.get("description", "")}
        if s.get("type") == "array":
            items = s.get("items") or (s.get("prefixItems") or [{"type": "number"}])[0]
            # the items' own bounds (a position's +-POSITION_LIMIT) come along
            schema = {"type": "array", "items": {k: v for k, v in items.items() if k in (
                "type", "minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum")}}
            schema["items"].setdefault("type", "number")
            for k in ("minItems", "maxItems"):
                if k in s:
                    schema[k] = s[k]
            p.update(schema=schema, style="form", explode=False)
        elif s.get("format") == "color":
            p["schema"] = {"type": "string", "pattern": "^[0-9a-fA-F]{6}$"}
            p["description"] += " (sRGB hex without '#')"
        else:
            p["schema"] = {k: v for k, v in s.items()
                           if k in ("type", "enum", "minimum", "maximum", "exclusiveMinimum",
                                    "exclusiveMaximum", "default")}
        return p

    def walk(schema: dict, prefix: str) -> None:
        for name, s in schema.get("properties", {}).items():
            path = prefix + name
            target = _resolve(s, defs)
            if target.get("type") == "object" or "properties" in target:
                walk(target, path + ".")
            elif s.get("type") == "array" and ("$ref" in s.get("items", {}) or "oneOf" in s.get("items", {})):
                params.append({"name": path, "in": "query", "required": False,
                               "description": f"how many items; then set each by index: {path}.0.<field>"
                                              + (", starting with kind" if "oneOf" in s["items"] else ""),
                               "schema": {"type": "integer", "minimum": 0,
                                          "maximum": s.get("maxItems", 64)}})
            else:
                params.append(leaf(path, s))
    walk(root, "")
    return params


def build(app) -> dict[str, Any]:
    doc = get_openapi(title=app.title, version=app.version, description=app.description, routes=app.routes)
    schemas = doc.setdefault("components", {}).setdefault("schemas", {})
    schemas.update(_schemas())
    paths = doc["paths"]
    get_still = paths["/api/still.{fmt}"]["get"]
    get_still["parameters"] = get_still.get("parameters", []) + query_parameters()
    get_still["description"] = (get_still.get("description", "") + "\n\n" + RULES).strip()
    post_still = paths["/api/still"]["post"]
    post_still["requestBody"] = {"required": False, "content": {"application/json": {
        "schema": {"$ref": REF.format(model="StillParams")}}},
        "description": "StillParams fields, a patch over the default preset"}
    post_still["description"] = (post_still.get("description", "") + "\n\n" + RULES).strip()
    for name in ("TransmittanceRequest", "SuggestRequest", "RayPlotRequest"):
        req = schemas.get(name)
        if req:
            req["properties"]["params"] = {"$ref": REF.format(model="FogParams"),
                                           "description": "a patch over the default preset"}
    paths["/api/transmittance"]["post"]["description"] = RULES
    paths["/api/layers/suggest"]["post"]["description"] = RULES
    paths["/api/plot/ray"]["post"]["description"] = (
        "The pixel (x, y) is inside the view: x < width and y < height (422 otherwise). " + RULES)
    paths["/api/layers/profile"]["post"]["description"] = (
        "points, when given, holds one value per point of the layer's profile: degree + 1 for a "
        "polynomial (len(coeffs)), 2 (len(terms) + 1) for a cosine (422 naming points otherwise). "
        "A shape that breaks a rule is not refused: it is answered with its problems. " + RULES)
    return doc
