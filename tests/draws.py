"""Random fog layers and rays for the tests (numpy Generator in, params out)."""

from __future__ import annotations

import numpy as np

from fogbank.model.params import (Cosine, CosineTerm, Distance, Height, Homogeneous, Noise, Particles,
                            Polynomial, Potential, Sphere, poly_min)

EXPONENTIAL = ["homogeneous", "height", "cosine", "polynomial", "potential", "sphere"]
ALL = EXPONENTIAL + ["particles", "noise", "distance"]


def unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def random_layer(kind, rng):
    wind = bool(rng.random() < 0.5)
    if kind == "homogeneous":
        return Homogeneous(density=rng.uniform(0, 0.05), wind=wind)
    if kind == "height":
        return Height(density=rng.uniform(0, 0.05), falloff=float(rng.choice([0.0, rng.uniform(0, 0.3)])),
                      base=rng.uniform(-10, 10), wind=wind)
    if kind == "cosine":
        n = int(rng.integers(1, 6))
        terms = [CosineTerm(amp=rng.uniform(-1, 1), k=tuple(rng.normal(size=3) * 3),
                            phase=rng.uniform(-3, 3)) for _ in range(n)]
        c0 = sum(abs(t.amp) for t in terms) + rng.uniform(0, 1)
        return Cosine(density=rng.uniform(0, 0.03), c0=c0, terms=terms, scale=rng.uniform(2, 40), wind=wind)
    if kind == "polynomial":
        C = rng.uniform(0.3, 2)
        while True:
            coeffs = list(rng.normal(size=int(rng.integers(1, 7))))
            lo = poly_min(coeffs, -C, C)
            if lo < 0:
                coeffs[0] -= lo - rng.uniform(0, 0.5)
            if poly_min(coeffs, -C, C) >= 0:
                break
        return Polynomial(density=rng.uniform(0, 0.03), coeffs=coeffs, half_width=C,
                          axis=tuple(rng.normal(size=3) / 15), offset=rng.uniform(-2, 2),
                          mode=str(rng.choice(["repeat", "zero"])), wind=wind)
    if kind == "potential":
        return Potential(shape=str(rng.choice(["point", "line"])), center=tuple(rng.normal(size=3) * 10),
                         direction=tuple(rng.normal(size=3)), strength=rng.uniform(0, 2),
                         c=rng.uniform(0.5, 30), e=rng.uniform(0.01, 2), wind=wind)
    if kind == "sphere":
        return Sphere(center=tuple(rng.normal(size=3) * 8), radius=rng.uniform(1, 20),
                      density=rng.uniform(0, 0.3), wind=wind)
    if kind == "particles":
        return Particles(count=int(rng.integers(1, 200)), emitter=tuple(rng.normal(size=3) * 5),
                         direction=tuple(rng.normal(size=3)), spread=rng.uniform(0, 90),
                         speed=rng.uniform(0, 3), radius=rng.uniform(1, 8), alpha=rng.uniform(0, 1),
                         life_min=8, life_max=int(rng.integers(8, 64)), step=rng.uniform(0.05, 0.5),
                         seed=int(rng.integers(0, 1000)), wind=wind)
    if kind == "noise":
        return Noise(mode=str(rng.choice(["surface", "volume"])), density=rng.uniform(0, 0.05),
                     scale=rng.uniform(5, 100), height_falloff=bool(rng.random() < 0.5),
                     falloff_scale=rng.uniform(2, 30), samples=int(rng.integers(1, 24)), wind=wind)
    if kind == "distance":
        return Distance(start=rng.uniform(0, 30), distance=rng.uniform(20, 400), exponent=rng.uniform(0.2, 3),
                        low=rng.uniform(0, 1), high=rng.uniform(0, 2), max=rng.uniform(0, 1),
                        noise_scale=rng.uniform(5, 100), wind=wind)
    raise AssertionError(kind)


def random_rays(rng, n, max_len=150.0):
    O = rng.normal(size=(n, 3)) * 15
    W = unit(rng.normal(size=(n, 3)))
    D = rng.uniform(0, max_len, n)
    # a few degenerate rays: along the axes and of zero length
    axes = unit(np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, -1, 0], [-1, 0, 0], [0, 0, -1]], float))
    W[:6] = axes
    D[6] = 0.0
    return O, W, D
