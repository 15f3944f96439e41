"""A whole fog's transmittance along rays in float64, composed as the shader composes it.

T = exp(-(max(density sum tau_i, 0) - density sum log T_j)) (the density scales the
optical depth before the exponential; a carving body's negative depth never takes the
exponential layers' sum below 0, and does not carve the direct layers), with the global effects applied as in
render/shaders/fog/transmittance.glsl: the segment starts at `start_distance`, points
beyond `cutoff_distance` get no fog or all fog (`cutoff_mode`), and T never drops below
1 - `max_opacity`. Each
kind's own reference (its module's `optical_depth` or `log_transmittance`) comes from
the registry.
"""

from __future__ import annotations

import numpy as np

from fogbank.kinds import KINDS, noise_bake
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


def transmittance(fog, O, omega, d, t, *, states=None):
    """T along each ray. `states[i]` is the particle state of layer i for particle layers
    (all rays share one time then); by default it is simulated at t[0]."""
    O, omega, d, t = as_rays(O, omega, d, t)
    eff = fog.effects
    start = eff.start_distance
    O = O + omega * min(start, 1e300)  # the segment begins at the start distance
    dd = np.maximum(d - start, 0.0)
    # the noise tile only when an enabled layer samples it (a bake of a large tile takes
    # seconds and hundreds of MB)
    tex = noise_tex(fog) if any(l.enabled and KINDS[l.kind].uses_noise for l in fog.layers) else None
    tau = np.zeros(len(d))      # the exponential layers' optical depth, density inside
    log_direct = np.zeros(len(d))
    for i, layer in enumerate(fog.layers):
        if not layer.enabled:
            continue
        kind = KINDS[layer.kind]
        state = _state(fog, i, layer, float(t[0]), states) if kind.simulate else None
        env = _env(fog, fog.density, tex, state)
        if kind.optical_depth is not None:
            tau = tau + kind.optical_depth(layer, O, omega, dd, t, env)
        else:   # as a sum of logarithms: a product of clarities can underflow
            log_direct = log_direct + kind.log_transmittance(layer, O, omega, dd, t, env)
    # the exponential layers' depth kept at 0 or more (a carving body, of negative density,
    # removes fog and never adds light), the direct layers' added: as the shader's
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
