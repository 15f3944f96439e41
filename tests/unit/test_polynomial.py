"""Tiling of the polynomial kind (Biri 3.2.2): repeat refuses a tile whose borders differ,
mirror is seamless for any coefficients, checked against an independent triangle-wave
fold P(C - |((u + C) mod 4C) - 2C|) and against quadrature of that fold."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError
from scipy.integrate import quad

from fogbank.kinds.kind import Env
from fogbank.kinds.polynomial import Polynomial, density, optical_depth
from fogbank.model.params import FogParams

PAPER = [0.8, -1.0, 0.0, 0.0, 1.0]     # Biri's figure 7: P(-1) = 2.8, P(1) = 0.8
ENV = Env(wind=np.zeros(3))


def folded(coeffs, C, u):
    """The mirrored tiling written as a triangle wave, not as tiles and parities."""
    s = np.mod(u + C, 4 * C)
    return np.polynomial.polynomial.polyval(C - np.abs(s - 2 * C), coeffs)


def test_repeat_refuses_coefficients_whose_borders_differ():
    with pytest.raises(ValidationError) as e:
        FogParams(layers=[{"kind": "polynomial", "coeffs": PAPER, "mode": "repeat"}])
    err = e.value.errors()[0]
    assert err["loc"][:2] == ("layers", 0)
    assert "P(-1) = 2.8" in err["msg"] and "P(1) = 0.8" in err["msg"] and "'mirror'" in err["msg"]
    # equal borders (an even P) repeat; the paper's coefficients mirror, and mirror is the default
    assert Polynomial(coeffs=[1.0, 0.0, -0.5], mode="repeat").mode == "repeat"
    assert Polynomial(coeffs=PAPER).mode == "mirror"


@pytest.mark.parametrize("C", [1.0, 0.37, 250.0])
def test_mirror_equals_the_fold_and_is_continuous_at_every_border(C):
    layer = Polynomial(coeffs=PAPER, half_width=C, axis=(1.0, 0.0, 0.0), offset=0.0)
    rng = np.random.default_rng(int(C * 100))
    u = rng.uniform(-9 * C, 9 * C, 400)
    x = np.zeros((len(u), 3))
    x[:, 0] = u
    got = density(layer, x, np.zeros(len(u)), ENV)
    assert np.abs(got - layer.density * folded(PAPER, C, u)).max() <= 1e-9 * layer.density
    borders = (2 * np.arange(-4, 5) + 1) * C
    for eps in (1e-9 * C, 1e-6 * C):
        left, right = (np.zeros((len(borders), 3)) for _ in range(2))
        left[:, 0], right[:, 0] = borders - eps, borders + eps
        jump = density(layer, right, np.zeros(len(borders)), ENV) - density(layer, left, np.zeros(len(borders)), ENV)
        assert np.abs(jump).max() <= 1e-5 * layer.density   # the repeated tile jumps by 2.0 here


def test_mirrored_optical_depth_against_quadrature_of_the_fold():
    rng = np.random.default_rng(7)
    for _ in range(150):
        C = float(rng.uniform(0.2, 3.0))
        coeffs = PAPER if rng.random() < 0.5 else [1.5, 0.3, 0.2]
        a = rng.normal(size=3) * rng.choice([0.01, 0.1, 1.0])
        layer = Polynomial(coeffs=coeffs, half_width=C, axis=tuple(a), offset=float(rng.uniform(-20, 20)),
                           density=0.02)
        O = rng.normal(size=3) * rng.choice([1.0, 100.0, 1e4])
        w = rng.normal(size=3)
        w /= np.linalg.norm(w)
        d = float(rng.uniform(0, 300))
        u0, rate = float(O @ a + layer.offset), float(w @ a)
        lo, hi = sorted((u0, u0 + rate * d))
        pts = [(2 * k + 1) * C for k in range(int(np.floor((lo - C) / (2 * C))), int(np.ceil((hi - C) / (2 * C))) + 1)
               if lo < (2 * k + 1) * C < hi]
        if hi == lo:
            ref = 0.02 * d * float(folded(coeffs, C, u0))
        else:    # piece by piece between the fold's kinks
            edges = [lo] + pts + [hi]
            ref = sum(quad(lambda u: folded(coeffs, C, u), x0, x1, epsabs=1e-14, epsrel=1e-12)[0]
                      for x0, x1 in zip(edges, edges[1:])) / abs(rate) * 0.02
        got = float(optical_depth(layer, O[None], w[None], np.array([d]), np.array([0.0]), ENV)[0])
        assert abs(got - ref) <= 1e-7 * abs(ref) + 1e-10
