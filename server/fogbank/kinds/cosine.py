"""Cosine fog (Biri 3.2.1): rho (c0 + sum c_i cos(k_i . x / scale + phi_i))."""

from __future__ import annotations

import numpy as np

from fogbank.kinds.rays import slide


def density(layer, x, t, wind):
    x = slide(layer, x, t, wind) / layer.scale
    s = np.full(len(x), layer.c0)
    for term in layer.terms:
        s = s + term.amp * np.cos(x @ np.asarray(term.k) + term.phase)
    return layer.density * s


def _phases(term, layer, O, t, wind):
    """Each ray's phase k . (O - wind t) / scale + phase, reduced to [-pi, pi) (exactly where
    it is large: late times, fine waves), as layers.pack reduces it for the shader."""
    from fogbank.kinds.packing import EXACT_ABOVE, phase_at
    w = np.asarray(wind, dtype=np.float64) if layer.wind else np.zeros(3)
    k = np.asarray(term.k, dtype=np.float64)
    x = ((O - w[None, :] * t[:, None]) @ k) / layer.scale + term.phase
    big = (np.abs(O) + np.abs(w)[None, :] * t[:, None]) @ np.abs(k) / layer.scale + abs(term.phase)
    A = x - 2 * np.pi * np.floor(x / (2 * np.pi) + 0.5)
    for i in np.nonzero(big >= EXACT_ABOVE)[0]:
        A[i] = phase_at(k, O[i], w, float(t[i]), layer.scale, term.phase)
    return A


def optical_depth(layer, O, omega, d, t, wind):
    # integral of cos(A + B s) over [0, d] = d cos(A + B d / 2) sinc(B d / 2)
    tau = layer.c0 * d
    for term in layer.terms:
        k = np.asarray(term.k, dtype=np.float64)
        A = _phases(term, layer, O, t, wind)
        B = (omega @ k) / layer.scale
        h = B * d / 2.0
        tau = tau + term.amp * d * np.cos(A + h) * np.sinc(h / np.pi)
    return layer.density * tau
