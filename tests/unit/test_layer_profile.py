"""The function editor's data (model/layer_profile.py) against hand-written references:
the polynomial through the dragged points, the tiling written out by hand, the cosine
coefficients recovered from points made from known ones, and the rules named where a
shape breaks them."""

from __future__ import annotations

import numpy as np
import pytest

from fogbank.kinds.cosine import Cosine
from fogbank.kinds.polynomial import Polynomial
from fogbank.model.layer_profile import profile

pytestmark = pytest.mark.unit


def hand_tiled(coeffs, C, mode, u):
    """P of the tile that u falls in: tile n covers [(2n - 1) C, (2n + 1) C); mirror
    reflects odd tiles, repeat shifts, zero is P on [-C, C] only."""
    out = []
    for x in u:
        n = int(np.floor((x + C) / (2 * C)))
        r = x - 2 * C * n
        if mode == "mirror" and n % 2:
            r = -r
        if mode == "zero" and n != 0 and not (x == C):
            out.append(0.0)
            continue
        out.append(sum(c * r ** i for i, c in enumerate(coeffs)))
    return np.array(out)


@pytest.mark.parametrize("mode", ["mirror", "repeat", "zero"])
def test_the_polynomial_through_the_dragged_points(mode):
    layer = Polynomial(coeffs=[1.0, 0.0, 1.0], half_width=2.0, mode=mode, axis=(0.1, 0.0, 0.0), offset=0.3)
    base = profile(layer)
    knots = [p[0] for p in base["points"]]
    assert knots == [-2.0, 0.0, 2.0]
    assert [p[1] for p in base["points"]] == [5.0, 1.0, 5.0]
    values = [2.0, 0.5, 2.0]
    got = profile(layer, values)
    c = got["fitted"]["coeffs"]
    assert np.allclose([sum(ci * k ** i for i, ci in enumerate(c)) for k in knots], values, atol=1e-12)
    assert np.allclose(got["shape"], hand_tiled(c, 2.0, mode, np.array(got["u"])), atol=1e-9)
    assert got["problems"] == []


def test_a_dip_below_zero_is_named_with_where():
    layer = Polynomial(coeffs=[1.0, 0.0, 1.0], half_width=1.0)
    got = profile(layer, [1.0, -0.25, 1.0])
    (bad,) = got["problems"]
    assert bad["rule"] == "negative" and bad["at"] == pytest.approx(0.0, abs=1e-3)
    assert bad["value"] == pytest.approx(-0.25)
    assert "< 0" in bad["msg"]


def test_repeat_mode_names_the_jump_at_the_border():
    layer = Polynomial(coeffs=[1.0, 0.0, 1.0], half_width=1.0, mode="repeat")
    (bad,) = profile(layer, [2.0, 1.0, 1.5])["problems"]
    assert bad["rule"] == "jump" and bad["value"] == pytest.approx(-0.5)
    assert profile(layer.model_copy(update={"mode": "mirror"}), [2.0, 1.0, 1.5])["problems"] == []


def test_cosine_coefficients_follow_points_made_from_known_ones():
    layer = Cosine(c0=1.0, scale=10.0, terms=[{"amp": 0.3, "k": (0.0, 1.0, 0.0), "phase": 0.4},
                                            {"amp": 0.2, "k": (0.0, 3.0, 0.0), "phase": -1.0}])
    base = profile(layer)
    period = 2 * np.pi * 10.0
    assert base["tile"] == [0.0, pytest.approx(period)]
    s = np.array([p[0] for p in base["points"]])
    want = {"c0": 1.4, "amps": [-0.5, 0.35]}
    values = want["c0"] + want["amps"][0] * np.cos(s / 10.0 + 0.4) + want["amps"][1] * np.cos(3 * s / 10.0 - 1.0)
    got = profile(layer, list(values))
    assert got["fitted"]["c0"] == pytest.approx(1.4, abs=1e-9)
    assert [t["amp"] for t in got["fitted"]["terms"]] == pytest.approx(want["amps"], abs=1e-9)
    u = np.array(got["u"])
    shape = 1.4 - 0.5 * np.cos(u / 10.0 + 0.4) + 0.35 * np.cos(3 * u / 10.0 - 1.0)
    assert np.allclose(got["shape"], shape, atol=1e-9)
    assert got["problems"] == []
    (bad,) = profile(layer, list(values - 1.0))["problems"]      # c0 0.4 < 0.5 + 0.35
    assert bad["rule"] == "negative" and bad["value"] < 0


def test_wrong_point_counts_and_kinds_say_what_is_allowed():
    with pytest.raises(ValueError, match="points: 5 values"):
        profile(Polynomial(), [1.0, 2.0])
    from fogbank.kinds.homogeneous import Homogeneous
    with pytest.raises(ValueError, match="polynomial and cosine"):
        profile(Homogeneous())


def test_a_fit_the_model_would_refuse_is_a_problem_not_a_surprise():
    """Fits out of the model's ranges (c0 over 100, an amplitude over 10, a coefficient
    over 1e6 from a tiny tile) are named as problems, so the page never sends them."""
    cos = Cosine(c0=1.0, terms=[{"amp": 0.5, "k": (0.0, 1.0, 0.0)}])
    (bad,) = profile(cos, [150.0, 150.0, 150.0, 150.0])["problems"]
    assert bad["rule"] == "range" and bad["msg"].startswith("c0:")
    (bad,) = profile(cos, [60.0, 30.0, 0.0, 30.0])["problems"]
    assert bad["rule"] == "range" and "amp" in bad["msg"]
    poly = Polynomial(coeffs=[0.0] * 8, half_width=0.0010001)
    got = profile(poly, [float(i) for i in range(1, 9)])
    assert max(abs(c) for c in got["fitted"]["coeffs"]) > 1e6
    assert [p["rule"] for p in got["problems"]] == ["range"]
    # and every fit offered without a problem is one the model takes
    for pts in ([1.0, 1.5, 1.0, 0.5], [2.0, 1.0, 0.0, 1.0]):
        out = profile(cos, pts)
        if not out["problems"]:
            Cosine.model_validate({**cos.model_dump(), **out["fitted"]})
