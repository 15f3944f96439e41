"""Views that teach (render/teach.py) against float64 references on the calibration
scene: rays cast by hand through every pixel centre (tests/hand.py), T and each layer's
optical depth from kinds/reference.py, and the raymarch's own error from a numpy
midpoint rule of the float64 densities."""

from __future__ import annotations

import numpy as np
import pytest

from fogbank.kinds import KINDS
from fogbank.kinds.kind import Env
from fogbank.kinds.reference import transmittance as reference
from fogbank.model.params import StillParams
from fogbank.render import teach
from hand import cast, hand_rays

W, H = 160, 90
LAYERS = [{"kind": "height", "density": 0.04, "falloff": 0.15, "base": 0.0},
          {"kind": "sphere", "center": (-4.0, 4.0, -45.0), "radius": 14.0, "density": 0.09},
          # a tight blob: 256 midpoint samples over 400 m miss part of its peak
          {"kind": "potential", "center": (6.0, 5.0, -70.0), "strength": 2.0, "c": 0.5, "e": 4.0}]


def still(layers=LAYERS):
    return StillParams.model_validate(dict(
        scene="calibration", width=W, height=H, time=2.0, layers=layers,
        camera={"position": (0.0, 6.0, 0.0), "yaw": 0.0, "pitch": -6.0, "fov": 60.0},
        effects={"scatter": 0.0, "sky_distance": 400.0, "fog_scale": 1}))


def rays(s):
    """(eye, unit rays, lengths, interior mask) for every pixel, top row first; the mask
    keeps pixels whose 3x3 neighbours all see the same object (no edge texel)."""
    py, px = np.mgrid[H - 1:-1:-1, 0:W]
    w = hand_rays(s.camera, px.ravel(), py.ravel(), W, H)
    eye = np.asarray(s.camera.position, dtype=np.float64)
    d, obj = cast(eye, w)
    d = np.where(obj < 0, s.effects.sky_distance, d)
    obj = obj.reshape(H, W)
    pad = np.pad(obj, 1, mode="edge")
    same = np.ones((H, W), bool)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            same &= pad[1 + dy:H + 1 + dy, 1 + dx:W + 1 + dx] == obj
    return eye, w, d, same.ravel()


def test_the_transmittance_view_is_t_from_the_float64_reference(renderer):
    s = still()
    img, stats = teach.render(renderer, s, "transmittance")
    assert img.shape == (H, W, 3)
    eye, w, d, inner = rays(s)
    want = reference(s, np.tile(eye, (len(w), 1)), w, d, np.full(len(w), s.time))
    got = img[..., 0].ravel() / 255.0
    assert float(np.abs(got - want)[inner].max()) <= 0.6 / 255 + 1e-3
    assert abs(stats["mean"] - float(want.mean())) <= 0.01
    assert stats["legend"]["lo"] == 0.0 and stats["legend"]["hi"] == 1.0


def test_the_optical_depth_view_is_one_layers_tau_on_its_scale(renderer):
    s = still()
    img, stats = teach.render(renderer, s, "optical_depth", 1)
    eye, w, d, inner = rays(s)
    alone = s.model_copy(update={"layers": [s.layers[1]]})
    tau = -np.log(reference(alone, np.tile(eye, (len(w), 1)), w, d, np.full(len(w), s.time)))
    assert stats["kind"] == "sphere" and stats["layer"] == 1
    assert stats["p99"] == pytest.approx(float(np.percentile(tau[tau > 0], 99)), rel=0.02)
    assert stats["max"] == pytest.approx(float(tau.max()), rel=0.02)
    # each pixel's colour: tau on the legend's scale (its stops are the legend's colours)
    stops = np.array([[int(c[i:i + 2], 16) for i in (1, 3, 5)] for c in stats["legend"]["colors"]], float)
    want = teach.colour(tau / stats["legend"]["hi"], stops)
    diff = np.abs(img.reshape(-1, 3).astype(int) - want.astype(int)).max(axis=1)
    assert float(np.percentile(diff[inner], 99)) <= 3
    with pytest.raises(ValueError, match="view.layer = 3: this look has 3 layer"):
        teach.render(renderer, s, "optical_depth", 3)


def test_a_layer_that_covers_little_of_the_view_still_shows(renderer):
    """A small sphere far off covers well under 1% of the pixels: its scale's top is the
    99th percentile of the pixels it covers, not 0 (a flat picture)."""
    layers = [{"kind": "sphere", "center": (30.0, 4.0, -150.0), "radius": 3.0, "density": 0.3}]
    s = still(layers)
    img, stats = teach.render(renderer, s, "optical_depth", 0)
    eye, w, d, inner = rays(s)
    tau = -np.log(reference(s, np.tile(eye, (len(w), 1)), w, d, np.full(len(w), s.time)))
    assert 0 < float((tau > 0).mean()) < 0.01
    assert stats["legend"]["hi"] == pytest.approx(float(np.percentile(tau[tau > 0], 99)), rel=0.05)
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 5


def midpoint(s, eye, w, d, steps):
    """T by the midpoint rule with `steps` samples of the float64 densities."""
    h = d / steps
    tau = np.zeros(len(w))
    env = Env(wind=s.wind.vector())
    for i in range(steps):
        x = eye + w * (h * (i + 0.5))[:, None]
        for layer in s.layers:
            tau += KINDS[layer.kind].density(layer, x, np.full(len(w), s.time), env) * h
    return np.exp(-tau)


def test_the_difference_view_is_the_raymarchs_own_error(renderer):
    """|T analytic - T raymarch| is the midpoint rule's error: the closed forms are the
    float64 reference, so the view's max and 99th percentile are those of |T_exact -
    T_midpoint| computed here in float64 with the same 256 samples."""
    s = still()
    img, stats = teach.render(renderer, s, "difference")
    eye, w, d, inner = rays(s)
    exact = reference(s, np.tile(eye, (len(w), 1)), w, d, np.full(len(w), s.time))
    want = np.abs(exact - midpoint(s, eye, w, d, teach.RAYMARCH_STEPS))
    assert stats["steps"] == teach.RAYMARCH_STEPS
    assert want[inner].max() > 5e-4                      # the tight blob is undersampled
    assert stats["max_abs_dT"] == pytest.approx(float(want.max()), rel=0.05, abs=5e-5)
    assert stats["p99_abs_dT"] == pytest.approx(float(np.percentile(want, 99)), rel=0.05, abs=5e-5)
