"""The generated GLSL depends only on the layer variant key (kinds from a fixed list,
booleans, small counts): no text a user sends can reach the shader source."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from draws import ALL, random_layer
from fogbank.kinds.packing import density_code, layer_code, variant
from fogbank.model.params import FogParams


def test_generated_glsl_comes_only_from_the_variant_key():
    rng = np.random.default_rng(3)
    for _ in range(200):
        fog = FogParams(layers=[random_layer(str(rng.choice(ALL)), rng) for _ in range(int(rng.integers(0, 16)))])
        key = variant(fog)
        for kind, terms in key:
            assert kind in {"homogeneous", "height", "cosine", "polynomial", "potential", "sphere",
                            "particles", "noise/surface", "noise/volume", "distance"}
            assert type(terms) is int and 0 <= terms <= 8
        # same key, same code, whatever the parameter values
        assert layer_code(key) == layer_code(variant(FogParams.model_validate(fog.model_dump())))
        assert isinstance(density_code(key), str)


@pytest.mark.parametrize("patch", [
    {"fog_color": "#abc; } void main() {"},
    {"layers": [{"kind": "sphere; discard;"}]},
    {"effects": {"blur": "single\n#define X"}},
    {"noise": {"size": "64; }"}},
])
def test_strings_never_pass_into_the_look(patch):
    with pytest.raises(ValidationError):
        FogParams.model_validate(patch)
