"""Packs a fog's layers into the uniforms of shaders/fog/transmittance.glsl.

One layer is LAYER_VEC4 vec4s plus an ivec4 header (kind, wind-sensitive, count, 0); the
comments in transmittance.glsl give each kind's slots. Particle positions go to a texture.
"""

from __future__ import annotations

import numpy as np
from numpy.polynomial import polynomial as npoly

from .params import (MAX_LAYERS, MAX_PARTICLES, Cosine, Distance, FogParams, Height,
                     Homogeneous, Noise, Particles, Polynomial, Potential, Sphere)

LAYER_VEC4 = 12
KINDS = ["homogeneous", "height", "cosine", "polynomial", "potential", "sphere", "particles",
         "noise", "distance"]
DEFINES = {"MAX_LAYERS": MAX_LAYERS, "LAYER_VEC4": LAYER_VEC4}


def pack(fog: FogParams, particle_states: dict[int, tuple[np.ndarray, np.ndarray]]):
    """Returns (count, heads int32 (MAX_LAYERS, 4), data float32 (MAX_LAYERS*LAYER_VEC4, 4),
    particles float32 (MAX_PARTICLES, 4))."""
    heads = np.zeros((MAX_LAYERS, 4), np.int32)
    data = np.zeros((MAX_LAYERS * LAYER_VEC4, 4), np.float64)
    parts = np.zeros((MAX_PARTICLES, 4), np.float64)
    n = 0
    first = 0
    for i, layer in enumerate(fog.layers):
        if not layer.enabled:
            continue
        v = data[n * LAYER_VEC4:(n + 1) * LAYER_VEC4]
        count = 0
        if isinstance(layer, Homogeneous):
            v[0, 0] = layer.density
        elif isinstance(layer, Height):
            v[0, :3] = (layer.density, layer.falloff, layer.base)
        elif isinstance(layer, Cosine):
            count = len(layer.terms)
            v[0, :3] = (layer.density, layer.c0, 1.0 / layer.scale)
            for j, t in enumerate(layer.terms):
                v[1 + j] = (*t.k, t.phase)
                v[9 + j // 4, j % 4] = t.amp
        elif isinstance(layer, Polynomial):
            C = layer.half_width
            c = np.zeros(8)
            c[:len(layer.coeffs)] = layer.coeffs
            Q = npoly.polyint(c)  # Q[0] = 0, Q[i+1] = c_i / (i + 1)
            period = npoly.polyval(C, Q) - npoly.polyval(-C, Q)
            v[0] = (*layer.axis, layer.offset)
            v[1] = (layer.density, C, 1.0 if layer.mode == "repeat" else 0.0, period)
            v[2], v[3] = c[:4], c[4:]
            v[4], v[5] = Q[1:5], Q[5:9]
        elif isinstance(layer, Potential):
            axis = np.zeros(3)
            if layer.shape == "line":
                axis = np.asarray(layer.direction, dtype=np.float64)
                axis /= np.linalg.norm(axis)
            v[0] = (*layer.center, layer.strength)
            v[1] = (*axis, layer.c)
            v[2, 0] = layer.e
        elif isinstance(layer, Sphere):
            v[0] = (*layer.center, layer.radius)
            v[1, 0] = layer.density
        elif isinstance(layer, Particles):
            pos, strength = particle_states[i]
            count = len(pos)
            parts[first:first + count, :3] = pos
            parts[first:first + count, 3] = strength
            v[0, :3] = (layer.alpha, layer.radius, first)
            first += count
        elif isinstance(layer, Noise):
            v[0] = (layer.density, 1.0 / layer.scale, 1.0 if layer.mode == "volume" else 0.0,
                    layer.samples)
            v[1, :2] = (1.0 if layer.height_falloff else 0.0, 1.0 / layer.falloff_scale)
        elif isinstance(layer, Distance):
            v[0] = (layer.start, 1.0 / layer.distance, layer.exponent, layer.max)
            v[1, :3] = (layer.low, layer.high, 1.0 / layer.noise_scale)
        heads[n] = (KINDS.index(layer.kind), 1 if layer.wind else 0, count, 0)
        n += 1
    return n, heads, data.astype(np.float32), parts.astype(np.float32)
