"""The separate blur (render/passes/blur.py, passes/blur.frag): two 1D Gaussian passes whose
sigma follows the fog. Issue 32's finding 3: at radius 12 the taps, read from the full
image sigma/2 apart, left stripe-shaped ghost copies of a sharp edge. Here a step edge
under full fog, blurred by the pass itself, against the step blurred by a Gaussian of the
asked sigma in float64 (the error function)."""

from __future__ import annotations

from math import erf, sqrt
from types import SimpleNamespace

import numpy as np
import pytest

from fogbank.model.params import StillParams
from fogbank.render.passes.blur import BlurPass
from calibration import srgb_to_linear_array


def _blurred_step(renderer, sigma: float, width: int = 320, height: int = 48, edge: int = 160,
                  lo: float = 0.05, hi: float = 0.8) -> np.ndarray:
    """One row of the output: a vertical step from `lo` to `hi` (linear) at column `edge`,
    every pixel's fog amount 1 (so the blur's sigma is the radius), through BlurPass."""
    still = StillParams.model_validate({"width": width, "height": 720, "effects": {
        "blur": "separate", "blur_radius": sigma, "blur_exponent": 1.0, "tone_map": "none", "exposure": 0.0}})
    targets = renderer.caches.targets(width, height)
    (_, src), _ = targets.linear_pair()
    img = np.zeros((height, width, 4), np.float32)
    img[..., :3] = lo
    img[:, edge:, :3] = hi
    img[..., 3] = 1.0
    src.write(img.astype(np.float16).tobytes())
    BlurPass().run(renderer, SimpleNamespace(still=still, targets=targets))
    row = targets.read_image(3)[height // 2].astype(np.float64)
    return srgb_to_linear_array(row).mean(axis=1)


@pytest.mark.parametrize("sigma", [3.0, 6.0, 12.0, 16.0])
def test_a_step_blurs_into_the_gaussian_of_its_sigma(renderer, sigma):
    """Within 0.015 (2% of the step) of lo + (hi - lo) Phi((x + 0.5 - edge) / sigma) at
    every column away from the image's sides (the output's dither is half a level: 0.002
    here at most). At sigma 12 the old taps stepped: 0.07 off."""
    lo, hi, edge = 0.05, 0.8, 160
    got = _blurred_step(renderer, sigma, edge=edge, lo=lo, hi=hi)
    x = np.arange(len(got)) + 0.5 - edge
    ref = lo + (hi - lo) * np.array([0.5 * (1.0 + erf(v / (sigma * sqrt(2.0)))) for v in x])
    inner = slice(int(3 * sigma), len(got) - int(3 * sigma))
    err = np.abs(got - ref)[inner]
    print(f"\nsigma {sigma}: max |blur - Gaussian| {float(err.max()):.4f}")
    assert float(err.max()) <= 0.015
