"""Carving bodies (a box or an ellipsoid with carve > 0): fog removed only inside the body.

A carving body with strength kappa in (0, 1] removes the share kappa of every other
layer's fog inside itself (Godot's negative FogVolume, Biri 2002's subtracted objects): the
density there is rho(x) (1 - kappa m(x)), m in [0, 1] the body's profile, taken in K
nested shells (K = box.CARVE_SHELLS across the body's edge fade, one without it), each
removing 1/K. Along a ray, each shell's chord [s0, s1] is exact (slabs, a quadric), and
the other layers' optical depth over it is their own closed form over that segment, so

    tau = tau_plain(0, d) - sum over bodies and shells of kappa / K tau_plain(s0, s1),

exact. Only the density layers are carved (the direct ones, particles and distance fog,
are not densities); bodies that overlap remove their shares twice, and the total is kept
at 0 or more (render/shaders/fog/transmittance.glsl fogDepths).
"""

from __future__ import annotations

import numpy as np

from fogbank.kinds import KINDS


def carving(layer) -> bool:
    return bool(getattr(layer, "carve", 0.0) > 0)


def carved_depth(fog, O, omega, d, t, plain, env) -> np.ndarray:
    """What the look's carving bodies take from the density layers' optical depth along
    the rays (>= 0): `plain(O, omega, d)` is the other density layers' optical depth over
    segments (float64, the global density inside)."""
    out = np.zeros(len(d))
    for layer in fog.layers:
        if not (layer.enabled and carving(layer)):
            continue
        for share, s0, s1 in KINDS[layer.kind].shell_chords(layer, O, omega, d, t, env):
            inside = s1 > s0
            if not inside.any():
                continue
            seg = np.zeros(len(d))
            seg[inside] = plain(O[inside] + omega[inside] * s0[inside, None], omega[inside],
                                (s1 - s0)[inside], t[inside])
            out += layer.carve * share * seg
    return out
