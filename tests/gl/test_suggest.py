"""A suggested new layer (model/suggest.py) is visible and never a white-out: each kind's
suggestion for a look, drawn alone by the frame's own fog passes, leaves the view's
median fog transmittance at 0.4 or more of what the look's effects leave without layers,
and shows (some texel loses at least 2%). Before, a new layer came with its kind's bare
defaults: in the default view, homogeneous fog took the median T to 0.24, cosine to 0.19
and surface noise to 0.007."""

from __future__ import annotations

import numpy as np
import pytest

from fogbank.model.params import LAYER_CLASSES, FogParams, StillParams
from fogbank.model.presets import preset_dict
from fogbank.model.suggest import suggest_layer
from fogbank.render.probes import fog_only


def alone(look, layer):
    return StillParams.model_validate({**look.model_dump(mode="json"), "layers": [layer],
                                       "width": 160, "height": 90})


@pytest.mark.parametrize("preset", ["default", "biri-fig7", "quilez-spheres"])
def test_a_suggested_layer_is_visible_and_never_a_white_out(renderer, preset):
    look = FogParams.model_validate(preset_dict(preset))
    # the look's own effects without layers (biri-fig7's cutoff fills the far field with
    # fog whatever the layers): the new layer's share is T with it over T without
    _, base, _, _ = fog_only(renderer, StillParams.model_validate(
        {**look.model_dump(mode="json"), "layers": [], "width": 160, "height": 90}))
    seen = base > 0.5
    assert seen.mean() > 0.3
    for kind in LAYER_CLASSES:
        layer = suggest_layer(kind, look)
        # particles are born over time: seen 10 s on (at time 0 none is alive yet)
        at = look.model_copy(update={"time": look.time + 10.0}) if kind == "particles" else look
        _, T, _, _ = fog_only(renderer, alone(at, layer))
        share = T[seen] / base[seen]
        assert float(np.median(share)) >= 0.4, (kind, float(np.median(share)))
        assert float(share.min()) <= 0.98, (kind, float(share.min()))


def test_bare_defaults_failed_the_same_criterion(renderer):
    look = FogParams.model_validate(preset_dict("default"))
    medians = {}
    for kind in ("homogeneous", "height", "cosine", "noise"):
        _, T, _, _ = fog_only(renderer, alone(look, LAYER_CLASSES[kind]().model_dump(mode="json")))
        medians[kind] = float(np.median(T))
    assert min(medians.values()) < 0.4
