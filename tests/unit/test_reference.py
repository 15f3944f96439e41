"""Every closed form against adaptive quadrature of its density (float64, scipy.quad).

For each exponential kind: at least 100 random parameter and ray draws, plus the
degenerate rays (parallel to an axis, grazing a sphere, zero length). Relative error
<= 1e-6 (absolute 1e-12 for optical depths that are ~0).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from fogbank.kinds import KINDS
from fogbank.kinds.box import Box
from fogbank.kinds.ellipsoid import Ellipsoid
from fogbank.kinds.height import Height
from fogbank.kinds.kind import Env
from fogbank.kinds.polynomial import Polynomial
from fogbank.kinds.potential import Potential
from fogbank.kinds.sphere import Sphere
from draws import EXPONENTIAL, random_layer, unit
from quadrature import body_crossings

# every exponential kind with a density: a new kind is checked here without a test edit
MODULES = {name: KINDS[name] for name in EXPONENTIAL if KINDS[name].density is not None}
WIND = np.array([1.3, 0.2, -0.7])
ENV = Env(wind=WIND)


def breakpoints(layer, O, w, d, t):
    """Kinks of the integrand along the ray, so that quad integrates smooth pieces."""
    pts = []
    if isinstance(layer, Polynomial):
        a = np.asarray(layer.axis)
        Os = O - (WIND * t if layer.wind else 0)
        u0, rate = Os @ a + layer.offset, w @ a
        C = layer.half_width
        if abs(rate) > 1e-12:
            u1 = u0 + rate * d
            lo, hi = sorted((u0, u1))
            k0, k1 = int(np.floor((lo - C) / (2 * C))), int(np.ceil((hi + C) / (2 * C)))
            for k in range(k0, k1 + 1):
                for edge in (-C + 2 * C * k, C + 2 * C * k):
                    s = (edge - u0) / rate
                    if 0 < s < d:
                        pts.append(s)
    if isinstance(layer, Sphere):
        c = np.asarray(layer.center) + (WIND * t if layer.wind else 0)
        b = w @ (O - c)
        h = b * b - (O - c) @ (O - c) + layer.radius**2
        if h > 0:
            pts += [s for s in (-b - np.sqrt(h), -b + np.sqrt(h)) if 0 < s < d]
    if isinstance(layer, (Box, Ellipsoid)):   # where the ray enters and leaves the body
        pts += body_crossings(layer, O - (WIND * t if layer.wind else 0), w, d)
    return sorted(pts)[:200]


def quadrature(layer, O, w, d, t):
    mod = MODULES[layer.kind]
    if d == 0:
        return 0.0

    def f(s):
        x = (O + w * s)[None, :]
        return float(mod.density(layer, x, np.array([t]), ENV)[0])

    val, err = quad(f, 0.0, d, points=breakpoints(layer, O, w, d, t) or None, limit=2000,
                    epsabs=1e-14, epsrel=1e-12)
    return val


def closed(layer, O, w, d, t):
    mod = MODULES[layer.kind]
    return float(mod.optical_depth(layer, O[None, :], w[None, :], np.array([d]), np.array([t]),
                                   ENV)[0])


def check(layer, O, w, d, t):
    ref = quadrature(layer, O, w, d, t)
    got = closed(layer, O, w, d, t)
    assert np.isfinite(got)
    assert abs(got - ref) <= 1e-6 * abs(ref) + 1e-12, (layer, O, w, d, t, got, ref)


@pytest.mark.parametrize("kind", sorted(MODULES))
def test_random_draws_match_quadrature(kind):
    rng = np.random.default_rng(sorted(MODULES).index(kind))
    for _ in range(120):
        layer = random_layer(kind, rng)
        O = rng.normal(size=3) * 15
        w = unit(rng.normal(size=3))
        d = rng.uniform(0, 120)
        t = rng.uniform(0, 10)
        check(layer, O, w, d, t)


AXES = [unit(v) for v in ([1, 0, 0], [0, 1, 0], [0, 0, 1], [0, -1, 0], [-1, 0, 0])]


@pytest.mark.parametrize("kind", sorted(MODULES))
def test_degenerate_rays(kind):
    rng = np.random.default_rng(100 + sorted(MODULES).index(kind))
    for _ in range(20):
        layer = random_layer(kind, rng)
        O = rng.normal(size=3) * 15
        for w in AXES:
            check(layer, O, w, rng.uniform(0, 80), rng.uniform(0, 5))   # parallel to an axis
        check(layer, O, AXES[0], 0.0, 1.0)                               # zero length
        assert closed(layer, O, AXES[1], 0.0, 1.0) == 0.0


def test_polynomial_ray_orthogonal_to_axis_is_the_limit():
    layer = Polynomial(coeffs=[1.0, 0.5, 0.2], half_width=1.0, axis=(0.1, 0.0, 0.0))
    O, d = np.array([3.0, 1.0, 2.0]), 40.0
    for w in (np.array([0.0, 0.0, 1.0]), unit([1e-15, 0.0, 1.0])):
        check(layer, O, w, d, 0.0)
    assert closed(layer, O, np.array([0.0, 0.0, 1.0]), d, 0.0) == pytest.approx(
        0.02 * d * (1.0 + 0.5 * 0.3 + 0.2 * 0.09), rel=1e-12)


def test_line_potential_ray_along_the_line():
    layer = Potential(shape="line", center=(1.0, 2.0, 3.0), direction=(0.0, 0.0, 1.0),
                      strength=2.0, c=3.0, e=0.5)
    O = np.array([2.0, 2.0, -5.0])   # r = 1 from the line everywhere along +z
    got = closed(layer, O, np.array([0.0, 0.0, 1.0]), 30.0, 0.0)
    assert got == pytest.approx(30.0 * 2.0 / (3.0 + 0.5 * 1.0), rel=1e-12)


def test_sphere_grazing_and_missing_rays():
    layer = Sphere(center=(0.0, 0.0, 0.0), radius=5.0, density=0.4)
    x = np.array([0.0, 0.0, 1.0])
    for off in (5.0 - 1e-9, 5.0, 5.0 + 1e-9, 7.0):   # tangent, just inside, just outside
        O = np.array([off, 0.0, -20.0])
        check(layer, O, x, 40.0, 0.0)
    assert closed(layer, np.array([7.0, 0.0, -20.0]), x, 40.0, 0.0) == 0.0
    # through the centre: rho R * 4/3
    assert closed(layer, np.array([0.0, 0.0, -20.0]), x, 40.0, 0.0) == pytest.approx(
        0.4 * 5.0 * 4.0 / 3.0, rel=1e-12)


def test_height_horizontal_ray_is_the_limit():
    layer = Height(density=0.1, falloff=0.3, base=1.0)
    O = np.array([0.0, 4.0, 0.0])
    got = closed(layer, O, np.array([1.0, 0.0, 0.0]), 50.0, 0.0)
    assert got == pytest.approx(0.1 * 50.0 * np.exp(-0.3 * 3.0), rel=1e-14)


def test_box_slab_chord_by_hand():
    """An axis-aligned box crossed along x through its middle: tau = rho * its width; a
    rotated one (45 degrees about y) crossed along its diagonal: rho * 2 sqrt(2) h."""
    box = Box(center=(0.0, 0.0, 0.0), half_size=(2.0, 1.0, 3.0), density=0.25)
    assert closed(box, np.array([-10.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.0]), 30.0, 0.0) == pytest.approx(
        0.25 * 4.0, rel=1e-14)
    turned = Box(center=(0.0, 0.0, 0.0), half_size=(1.0, 1.0, 1.0), yaw=45.0, density=1.0)
    got = closed(turned, np.array([-10.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.0]), 30.0, 0.0)
    assert got == pytest.approx(2.0 * np.sqrt(2.0), rel=1e-12)
    # a ray parallel to a face, outside it, sees nothing; inside, all of its length in the box
    assert closed(box, np.array([-10.0, 1.5, 0.0]), np.array([1.0, 0.0, 0.0]), 30.0, 0.0) == 0.0
    assert closed(box, np.array([-1.0, 0.5, 0.0]), np.array([1.0, 0.0, 0.0]), 1.5, 0.0) == pytest.approx(0.25 * 1.5)


def test_ellipsoid_is_the_sphere_when_round_and_scales_with_its_radii():
    O, w = np.array([1.0, 2.0, -30.0]), unit([0.05, -0.02, 1.0])
    ball = Sphere(center=(0.5, 1.0, 2.0), radius=6.0, density=0.3)
    round_ = Ellipsoid(center=(0.5, 1.0, 2.0), radii=(6.0, 6.0, 6.0), density=0.3, yaw=30, pitch=10)
    assert closed(round_, O, w, 60.0, 0.0) == pytest.approx(closed(ball, O, w, 60.0, 0.0), rel=1e-12)
    # along z through the centre of semi-axes (a, b, c): rho * c * 4/3
    egg = Ellipsoid(center=(0.0, 0.0, 0.0), radii=(3.0, 2.0, 7.0), density=0.5)
    got = closed(egg, np.array([0.0, 0.0, -20.0]), np.array([0.0, 0.0, 1.0]), 40.0, 0.0)
    assert got == pytest.approx(0.5 * 7.0 * 4.0 / 3.0, rel=1e-12)


def test_a_carving_body_removes_fog_only_inside_itself():
    """carve: the share of the other layers' fog a body removes over its own chord, and
    nowhere else (a negative density took the same depth from fog anywhere on the ray)."""
    from pydantic import ValidationError
    from fogbank.kinds.homogeneous import Homogeneous
    from fogbank.kinds.reference import transmittance
    from fogbank.model.params import FogParams
    box = Box(center=(0.0, 0.0, 0.0), half_size=(5.0, 5.0, 5.0), carve=1.0).model_dump()
    fog = FogParams(layers=[Homogeneous(density=0.02).model_dump(), box])
    O, w = np.array([[-50.0, 0.0, 0.0]]), np.array([[1.0, 0.0, 0.0]])
    # 100 m of fog, 10 of them carved out: T = exp(-0.02 * 90)
    assert transmittance(fog, O, w, np.array([100.0]), 0.0)[0] == pytest.approx(np.exp(-0.02 * 90), rel=1e-12)
    half = FogParams(layers=[Homogeneous(density=0.02).model_dump(), {**box, "carve": 0.5}])
    assert transmittance(half, O, w, np.array([100.0]), 0.0)[0] == pytest.approx(np.exp(-0.02 * 95), rel=1e-12)
    # a ray that stops short of the body, or passes beside it, keeps all its fog
    assert transmittance(fog, O, w, np.array([40.0]), 0.0)[0] == pytest.approx(np.exp(-0.02 * 40), rel=1e-12)
    assert transmittance(fog, O + [0.0, 6.0, 0.0], w, np.array([100.0]), 0.0)[0] == pytest.approx(np.exp(-2.0))
    # alone it carves nothing: no fog, and none added
    assert transmittance(FogParams(layers=[box]), O, w, np.array([100.0]), 0.0)[0] == 1.0
    with pytest.raises(ValidationError, match="carve"):
        Box(density=-0.02)


@pytest.mark.parametrize("kind", sorted(MODULES))
def test_the_global_density_scales_every_optical_depth(kind):
    """env.weight (the global density) multiplies each kind's optical depth: the
    composition folds it in nowhere else."""
    rng = np.random.default_rng(200 + sorted(MODULES).index(kind))
    for _ in range(10):
        layer = random_layer(kind, rng)
        O, w = rng.normal(size=(1, 3)) * 15, unit(rng.normal(size=(1, 3)))
        d, t = np.array([rng.uniform(1, 120)]), np.array([rng.uniform(0, 10)])
        one = MODULES[kind].optical_depth(layer, O, w, d, t, Env(wind=WIND))[0]
        more = MODULES[kind].optical_depth(layer, O, w, d, t, Env(wind=WIND, weight=2.5))[0]
        assert more == pytest.approx(2.5 * one, rel=1e-12, abs=1e-300)


def test_turned_bodies_against_the_independent_rotation():
    """Box and ellipsoid turned on all three axes with unequal sizes, against chords found
    with tests/quadrature.py's own rotation (scipy's intrinsic Y-X'-Z''): a flipped sign
    or order in the kinds' axes() shows here, where the round or 45-degree cases cannot."""
    from quadrature import body_crossings, tau_body
    from fogbank.model.params import FogParams
    rng = np.random.default_rng(77)
    box = Box(center=(1.0, 2.0, -3.0), half_size=(6.0, 1.5, 3.0), yaw=30.0, pitch=20.0, roll=10.0,
              density=0.3)
    egg = Ellipsoid(center=(1.0, 2.0, -3.0), radii=(6.0, 1.5, 3.0), yaw=30.0, pitch=20.0, roll=10.0,
                    density=0.3)
    fog = FogParams()
    hits = 0
    for _ in range(200):
        O = rng.normal(size=3) * 12
        w = unit(np.array([1.0, 2.0, -3.0]) + rng.normal(size=3) * 2.0 - O)
        d = 40.0
        cuts = body_crossings(box, O, w, d)
        if len(cuts) == 2:   # in and out of the box within the ray
            hits += 1
            assert closed(box, O, w, d, 0.0) == pytest.approx(0.3 * (cuts[1] - cuts[0]), rel=1e-9)
        assert closed(egg, O, w, d, 0.0) == pytest.approx(tau_body(egg, fog, O, w, d, 0.0),
                                                          rel=1e-7, abs=1e-12)
    assert hits > 50



@pytest.mark.parametrize("mode,beyond", [("fog", 1.0 - 0.8), ("clear", 1.0)])
def test_cutoff_fills_with_fog_or_clears(mode, beyond):
    """Biri 4.2: a point beyond the viewing threshold gets the fog colour (T = 0, then the
    max opacity); Unreal's cutoff leaves it unfogged (T = 1). No fog at all (density 0)
    is no fog either way."""
    from fogbank.kinds.homogeneous import Homogeneous
    from fogbank.kinds.reference import transmittance
    from fogbank.model.params import FogParams
    fog = FogParams(layers=[Homogeneous(density=0.01).model_dump()],
                    effects={"cutoff_distance": 100.0, "cutoff_mode": mode, "max_opacity": 0.8})
    O, w = np.zeros((2, 3)), np.array([[1.0, 0.0, 0.0]] * 2)
    T = transmittance(fog, O, w, np.array([50.0, 150.0]), 0.0)
    assert T.tolist() == [pytest.approx(np.exp(-0.5)), pytest.approx(beyond)]
    none = fog.model_copy(update={"density": 0.0})
    assert transmittance(none, O, w, np.array([50.0, 150.0]), 0.0).tolist() == [1.0, 1.0]
