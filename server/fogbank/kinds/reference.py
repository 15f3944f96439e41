"""A whole fog's transmittance along rays, composed as the shader composes it.

T = exp(-density sum tau_i) * (T_particles * T_distance) ^ density (the density scales the
optical depth before the exponential), with the global effects applied as in
render/shaders/fog/transmittance.glsl: the segment starts at `start_distance`, points beyond
`cutoff_distance` get no fog, and T never drops below 1 - `max_opacity`.
"""

from __future__ import annotations

import numpy as np

from fogbank.kinds import noise_bake
from fogbank.model.params import FogParams, Noise, Particles, Distance
from fogbank.kinds import cosine
from fogbank.kinds import distance
from fogbank.kinds import height
from fogbank.kinds import homogeneous
from fogbank.kinds import noise
from fogbank.kinds import particles
from fogbank.kinds import polynomial
from fogbank.kinds import potential
from fogbank.kinds import sphere
from fogbank.kinds.rays import as_rays

EXPONENTIAL = {
    "homogeneous": homogeneous,
    "height": height,
    "cosine": cosine,
    "polynomial": polynomial,
    "potential": potential,
    "sphere": sphere,
}


def optical_depth(layer, fog: FogParams, O, omega, d, t, *, tex=None, weight=1.0):
    """An exponential layer's optical depth along the rays times `weight` (the global
    density), or None for a direct one."""
    wind = fog.wind.vector()
    if layer.kind == "height":
        return height.optical_depth(layer, O, omega, d, t, wind, weight)
    if isinstance(layer, Noise):
        return weight * noise.optical_depth(layer, tex, O, omega, d, t, wind, weight)
    tau = _optical_depth(layer, fog, O, omega, d, t, tex=tex)
    return None if tau is None else weight * tau


def _optical_depth(layer, fog: FogParams, O, omega, d, t, *, tex=None):
    wind = fog.wind.vector()
    if layer.kind in EXPONENTIAL:
        return EXPONENTIAL[layer.kind].optical_depth(layer, O, omega, d, t, wind)
    if isinstance(layer, Noise):
        return noise.optical_depth(layer, tex, O, omega, d, t, wind)
    return None


def layer_transmittance(layer, fog: FogParams, O, omega, d, t, *, tex=None, state=None):
    """One layer's T along the rays (no global effects)."""
    wind = fog.wind.vector()
    tau = optical_depth(layer, fog, O, omega, d, t, tex=tex)
    if tau is not None:
        return np.exp(-tau)
    if isinstance(layer, Distance):
        return distance.transmittance(layer, tex, O, omega, d, t, wind)
    if isinstance(layer, Particles):
        return particles.transmittance(layer, state, O, omega, d)
    raise ValueError(f"unknown layer kind {layer.kind!r}")


def transmittance(fog: FogParams, O, omega, d, t, *, states=None):
    """T along each ray. `states[i]` is the particle state of layer i for particle layers
    (all rays share one time then); by default it is simulated at t[0]."""
    from fogbank.kinds.particle_motion import simulate
    from fogbank.scene.terrain import flat, height as ground_height

    O, omega, d, t = as_rays(O, omega, d, t)
    eff = fog.effects
    start = eff.start_distance
    O = O + omega * min(start, 1e300)  # the segment begins at the start distance
    dd = np.maximum(d - start, 0.0)
    tex = noise_bake.bake(fog.noise.size, fog.noise.octaves, fog.noise.blur, fog.noise.seed)
    ground = flat if fog.scene == "calibration" else ground_height
    T = np.ones(len(d))
    tau = np.zeros(len(d))
    for i, layer in enumerate(fog.layers):
        if not layer.enabled:
            continue
        layer_tau = optical_depth(layer, fog, O, omega, dd, t, tex=tex, weight=fog.density)
        if layer_tau is not None:
            tau = tau + layer_tau
            continue
        if isinstance(layer, Particles):   # as a logarithm: the product can underflow
            state = (states or {}).get(i) or simulate(layer, float(t[0]), fog.wind.vector(), ground)
            log_t = particles.log_transmittance(layer, state, O, omega, dd)
            with np.errstate(invalid="ignore"):
                T = T * np.where(np.isneginf(log_t), 0.0, np.exp(fog.density * log_t))
            continue
        T = T * layer_transmittance(layer, fog, O, omega, dd, t, tex=tex) ** fog.density
    T = T * np.exp(-tau) if fog.density > 0 else np.ones(len(d))
    if eff.cutoff_distance > 0:
        T = np.where(d > eff.cutoff_distance, 1.0, T)
    return np.maximum(T, 1.0 - eff.max_opacity)
