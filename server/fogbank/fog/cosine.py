"""Cosine fog (Biri 3.2.1): rho (c0 + sum c_i cos(k_i . x / scale + phi_i))."""

from __future__ import annotations

import numpy as np

from ._ray import slide


def density(layer, x, t, wind):
    x = slide(layer, x, t, wind) / layer.scale
    s = np.full(len(x), layer.c0)
    for term in layer.terms:
        s = s + term.amp * np.cos(x @ np.asarray(term.k) + term.phase)
    return layer.density * s


def optical_depth(layer, O, omega, d, t, wind):
    # integral of cos(A + B s) over [0, d] = d cos(A + B d / 2) sinc(B d / 2)
    O = slide(layer, O, t, wind) / layer.scale
    tau = layer.c0 * d
    for term in layer.terms:
        k = np.asarray(term.k, dtype=np.float64)
        A = O @ k + term.phase
        B = (omega @ k) / layer.scale
        h = B * d / 2.0
        tau = tau + term.amp * d * np.cos(A + h) * np.sinc(h / np.pi)
    return layer.density * tau
