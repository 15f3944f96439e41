"""Carving bodies (a box or an ellipsoid with carve > 0): fog removed only inside the body.

A carving body with strength kappa in (0, 1] removes the share kappa of every other
layer's fog inside itself (Godot's negative FogVolume, Biri 2002's subtracted objects): the
density there is rho(x) (1 - kappa m(x)), m in [0, 1] the body's profile, taken in K
nested shells (K = box.CARVE_SHELLS across the body's edge fade, one without it), each
removing 1/K. Along a ray, each shell's chord [s0, s1] is exact (slabs, a quadric), and
the other layers' optical depth over it is their own closed form over that segment, so

    tau = tau_plain(0, d) - sum over bodies and shells of kappa / K tau_plain(s0, s1),

exact. The depth over a chord is taken as the whole ray's less the pieces outside it,
as the shader does; for surface-mode noise, which is no integral (rho times a segment's
length times the noise at the segment's end), that is the rule. Only the density layers are carved (the direct ones, particles and distance fog,
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
    whole = None
    for layer in fog.layers:
        if not (layer.enabled and carving(layer)):
            continue
        if whole is None:
            whole = plain(O, omega, d, t)
        for share, s0, s1 in KINDS[layer.kind].shell_chords(layer, O, omega, d, t, env):
            inside = s1 > s0
            if not inside.any():
                continue
            # the whole ray's depth less what lies outside the chord, [0, s0] and [s1, d],
            # as the shader takes it (kinds/packing.py carve_code): the same as the depth
            # over [s0, s1] for every layer that integrates a segment, and the shader's own
            # rule for surface-mode noise, which is no integral (rho times the segment's
            # length times the noise at its end point: the pieces' ends are not the chord's)
            kept = np.zeros(int(inside.sum()))
            Oi, wi, ti = O[inside], omega[inside], t[inside]
            for a, b in ((np.zeros_like(s0[inside]), s0[inside]), (s1[inside], d[inside])):
                some = b > a
                if some.any():
                    kept[some] += plain(Oi[some] + wi[some] * a[some, None], wi[some], (b - a)[some], ti[some])
            seg = np.zeros(len(d))
            seg[inside] = whole[inside] - kept
            out += layer.carve * share * seg
    return out
