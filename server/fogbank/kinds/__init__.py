"""The registry of fog layer kinds.

Each kind is one module here plus its GLSL file beside it (kinds/<name>.py and
kinds/<name>.glsl), and one line in REGISTERED below. The params union, the URL codec,
the JSON Schema, the generated GLSL, the packing, the cost estimate, the float64
references and the tests' draws all read KINDS; nothing else lists the kinds.
"""

from __future__ import annotations

import importlib

from fogbank.kinds.kind import Kind

# the order is the order of the params union (and of the page's kind menu)
REGISTERED = (
    "homogeneous",
    "height",
    "cosine",
    "polynomial",
    "potential",
    "sphere",
    "particles",
    "noise",
    "distance",
    "box",
    "ellipsoid",
)

KINDS: dict[str, Kind] = {}
for _name in REGISTERED:
    _kind = importlib.import_module(f"fogbank.kinds.{_name}").KIND
    if _kind.name != _name:
        raise ImportError(f"kinds/{_name}.py declares kind {_kind.name!r}")
    KINDS[_name] = _kind


def kind_of(layer) -> Kind:
    return KINDS[layer.kind]
