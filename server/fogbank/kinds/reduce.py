"""Float64 (and, where float64 is not enough, exact) reductions the kinds' packing uses:
phases and tile coordinates taken at the reference point and reduced to one period, a
float32 hi + lo split, and a polynomial's Taylor shift."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np

LOG_ZERO = -1e30   # log of a zero density: exp() of it is 0 in float32


TWO_PI = Fraction("6.283185307179586476925286766559005768394338798750211641949889184615632812572417997256069650684234136")
EXACT_ABOVE = 1e6   # |value| beyond which float64 (1e-16 relative) would lose 1e-10 of a period


def _linear(k, E, wind, time, scale, offset) -> tuple[float, Fraction | None]:
    """k . (E - wind time) / scale + offset: in float64, and exactly (a Fraction of the
    float64 inputs) when it is large enough for float64's rounding to matter."""
    x = float(np.dot(k, E - wind * time)) / scale + offset
    big = abs(float(np.dot(np.abs(k), np.abs(E) + np.abs(wind) * time))) / scale + abs(offset)
    if big < EXACT_ABOVE:
        return x, None
    F = [Fraction(float(v)) for v in k]
    exact = sum(f * (Fraction(float(e)) - Fraction(float(w)) * Fraction(float(time)))
                for f, e, w in zip(F, E, wind)) / Fraction(float(scale)) + Fraction(float(offset))
    return x, exact


def phase_at(k, E, wind, time, scale, phase) -> float:
    """A cosine term's phase k . (E - wind time) / scale + phase at the reference point,
    reduced to [-pi, pi) (exactly, when it is large: late times, fine waves)."""
    x, exact = _linear(k, E, wind, time, scale, phase)
    if exact is None:
        return float(x - 2 * np.pi * np.floor(x / (2 * np.pi) + 0.5))
    return float(exact - TWO_PI * math.floor(exact / TWO_PI + Fraction(1, 2)))


def coordinate_at(axis, E, wind, time, offset, period, C) -> float:
    """A polynomial's u = axis . (E - wind time) + offset at the reference point; with a
    period (2C repeated, 4C mirrored), reduced to [-C, period - C) (exactly, when it is
    large)."""
    x, exact = _linear(axis, E, wind, time, 1.0, offset)
    if period is None:
        return x
    if exact is None:
        return float(x - period * np.floor((x + C) / period))
    P, Cf = Fraction(float(period)), Fraction(float(C))
    return float(exact - P * math.floor((exact + Cf) / P))


def split(x: float) -> tuple[float, float]:
    """x as float32 hi + lo, hi + lo = x to ~1e-14 relative."""
    hi = float(np.float32(x))
    return hi, float(np.float32(x - hi))


def taylor_shift(c: np.ndarray, e: float) -> np.ndarray:
    """Coefficients of P(e + v) in v, from P(u) = sum c_i u^i (float64)."""
    out = np.zeros(len(c))
    for i, ci in enumerate(c):
        for k in range(i + 1):
            out[k] += ci * math.comb(i, k) * e ** (i - k)
    return out
