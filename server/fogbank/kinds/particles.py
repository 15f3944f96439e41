"""Particle fog (Fischer): T = prod_j (1 - alpha s_j clamp(1 - dist_j / R, 0, 1))."""

from __future__ import annotations

import numpy as np


def segment_distance(p, O, omega, d):
    """Distance from points p (M, 3) to each segment O -> O + omega d: (N, M). Fischer/Bourke:
    project onto the line, clamp the parameter to [0, d]."""
    rel = p[None, :, :] - O[:, None, :]
    u = np.clip(np.einsum("nmk,nk->nm", rel, omega), 0.0, d[:, None])
    closest = rel - u[:, :, None] * omega[:, None, :]
    return np.linalg.norm(closest, axis=2)


def log_transmittance(layer, state, O, omega, d):
    """log T, summed over particles as logarithms (a product of many clarities underflows
    float64: 900 of 0.25 is 1e-538), -inf where a particle is opaque."""
    pos, strength = state
    if len(pos) == 0:
        return np.zeros(len(d))
    dist = segment_distance(pos, O, omega, d)
    opacity = layer.alpha * strength[None, :] * np.clip(1.0 - dist / layer.radius, 0.0, 1.0)
    with np.errstate(divide="ignore"):
        return np.sum(np.log1p(-opacity), axis=1)


def transmittance(layer, state, O, omega, d):
    return np.exp(log_transmittance(layer, state, O, omega, d))
