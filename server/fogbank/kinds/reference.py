"""A whole fog's transmittance along rays in float64, composed as the shader composes it.

T = exp(-(max(density sum tau_i - carved, 0) - density sum log T_j)) (the density scales
the optical depth before the exponential; a carving body removes its share of the other
density layers' depth over its own chords, kinds/carving.py, never the direct layers'),
with the global effects applied as in
render/shaders/fog/transmittance.glsl: the segment starts at `start_distance`, points
beyond `cutoff_distance` get no fog or all fog (`cutoff_mode`), and T never drops below
1 - `max_opacity`. Each
kind's own reference (its module's `optical_depth` or `log_transmittance`) comes from
the registry.
"""

from __future__ import annotations

import numpy as np

from fogbank.kinds import KINDS, noise_bake
from fogbank.kinds.carving import carved_depth, carving
from fogbank.kinds.kind import Env
from fogbank.kinds.rays import as_rays


def _env(fog, weight=1.0, tex=None, state=None) -> Env:
    return Env(wind=fog.wind.vector(), weight=weight, tex=tex, state=state)


def noise_tex(fog):
    """The look's baked noise tile (cached by noise_bake)."""
    n = fog.noise
    return noise_bake.bake(n.size, n.octaves, n.blur, n.seed)


def _state(fog, index, layer, time, states):
    """A simulated layer's state (particles): given, or simulated by its kind at `time`."""
    if states and index in states:
        return states[index]
    return KINDS[layer.kind].simulate(layer, time, fog)


def simulated_states(fog, time: float) -> dict:
    """Every simulated layer's state at `time`, by layer index: for plots and probes that
    read one look's particles more than once (transmittance's `states`)."""
    return {i: KINDS[l.kind].simulate(l, time, fog) for i, l in enumerate(fog.layers)
            if KINDS[l.kind].simulate}


def log_layer(layer, fog, O, omega, d, t, *, tex=None, state=None, weight=1.0):
    """One layer's log T along the rays (no global effects): -tau for an exponential kind,
    weight * log T_j for a direct one."""
    kind = KINDS[layer.kind]
    env = _env(fog, weight, tex, state)
    if kind.optical_depth is not None:
        return -kind.optical_depth(layer, O, omega, d, t, env)
    log_t = kind.log_transmittance(layer, O, omega, d, t, env)
    with np.errstate(invalid="ignore"):
        return np.where(np.isneginf(log_t), -np.inf, weight * log_t)


def layer_transmittance(layer, fog, O, omega, d, t, *, tex=None, state=None):
    """One layer's T along the rays (no global effects)."""
    if tex is None and KINDS[layer.kind].uses_noise:
        tex = noise_tex(fog)
    if state is None and KINDS[layer.kind].simulate:
        state = _state(fog, -1, layer, float(np.asarray(t).reshape(-1)[0]), None)
    return np.exp(log_layer(layer, fog, O, omega, d, t, tex=tex, state=state))


def plain_optical_depth(fog, O, omega, d, t, tex=None) -> np.ndarray:
    """The density layers' optical depth along the rays, carving bodies left out, the
    global density inside."""
    tau = np.zeros(len(d))
    for layer in fog.layers:
        kind = KINDS[layer.kind]
        if layer.enabled and kind.optical_depth is not None and not carving(layer):
            tau = tau + kind.optical_depth(layer, O, omega, d, t, _env(fog, fog.density, tex))
    return tau


def _tex_for(fog, direct: bool = True):
    """The look's noise tile where an enabled layer samples it (a bake of a large tile
    takes seconds and hundreds of MB); `direct` False: only density layers count."""
    return noise_tex(fog) if any(l.enabled and KINDS[l.kind].uses_noise and
                                 (direct or KINDS[l.kind].optical_depth is not None)
                                 for l in fog.layers) else None


def exponential_optical_depth(fog, O, omega, d, t, tex=None) -> np.ndarray:
    """The density layers' optical depth, carving bodies applied (kinds/carving.py), not
    yet kept at 0 or more."""
    def plain(o, w, dd, tt):
        return plain_optical_depth(fog, o, w, dd, tt, tex)
    total = plain(O, omega, d, t)
    # a depth past float64 (height fog far below its base) stays infinite: the carving's
    # share of it is no number to subtract (T = 0 either way but where the body holds it
    # all, which the shader cannot tell either)
    with np.errstate(invalid="ignore"):
        return np.where(np.isinf(total), total, total - carved_depth(fog, O, omega, d, t, plain, _env(fog)))


def density_optical_depth(fog, O, omega, d, t):
    """The density layers' optical depth along the rays, the global density inside and
    kept at 0 or more (fog/transmittance.glsl fogDepths's tau, and max(tau, 0)): what a
    point's sunlight crosses (the direct layers are effects of the view, not media, and
    the start and cutoff distances belong to the view)."""
    O, omega, d, t = as_rays(O, omega, d, t)
    if fog.density <= 0:
        return np.zeros(len(d))
    return np.maximum(exponential_optical_depth(fog, O, omega, d, t, _tex_for(fog, direct=False)), 0.0)


def transmittance(fog, O, omega, d, t, *, states=None):
    """T along each ray. `states[i]` is the particle state of layer i for particle layers
    (all rays share one time then); by default it is simulated at t[0]."""
    O, omega, d, t = as_rays(O, omega, d, t)
    eff = fog.effects
    start = eff.start_distance
    O = O + omega * min(start, 1e300)  # the segment begins at the start distance
    dd = np.maximum(d - start, 0.0)
    tex = _tex_for(fog)
    # the exponential layers' optical depth, density inside, carving bodies applied
    tau = exponential_optical_depth(fog, O, omega, dd, t, tex)
    log_direct = np.zeros(len(d))
    for i, layer in enumerate(fog.layers):
        kind = KINDS[layer.kind]
        if not layer.enabled or kind.optical_depth is not None:
            continue
        state = _state(fog, i, layer, float(t[0]), states) if kind.simulate else None
        # as a sum of logarithms: a product of clarities can underflow
        log_direct = log_direct + kind.log_transmittance(layer, O, omega, dd, t, _env(fog, fog.density, tex, state))
    # the exponential layers' depth kept at 0 or more (overlapping carving bodies remove
    # their shares twice), the direct layers' added: as the shader's
    # exp(-(max(tau, 0) + tauDirect))
    with np.errstate(invalid="ignore"):
        total = np.where(np.isneginf(log_direct), np.inf,
                         np.maximum(tau, 0.0) - fog.density * log_direct)
    if fog.density <= 0:
        return np.ones(len(d))   # no fog, whatever the cutoff
    T = np.exp(-total)
    if eff.cutoff_distance > 0:   # beyond it: all fog (Biri 4.2) or none (Unreal)
        T = np.where(d > eff.cutoff_distance, 0.0 if eff.cutoff_mode == "fog" else 1.0, T)
    return np.maximum(T, 1.0 - eff.max_opacity)
