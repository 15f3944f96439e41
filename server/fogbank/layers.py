"""Packs a fog's layers into the uniforms of shaders/fog/transmittance.glsl, and writes
the GLSL that calls each layer's function (fog/layers.gen.glsl).

One layer is LAYER_VEC4 vec4s of uLayer; `_CODE` below gives each kind's slots. Particle
positions go to a texture. The generated code depends only on `variant(fog)` (the kinds,
their wind flags and term counts), so one compiled program serves every value of the
parameters; the renderer caches programs by that key.
"""

from __future__ import annotations

import numpy as np
from numpy.polynomial import polynomial as npoly

from .params import (MAX_LAYERS, MAX_PARTICLES, Cosine, Distance, FogParams, Height,
                     Homogeneous, Noise, Particles, Polynomial, Potential, Sphere)

LAYER_VEC4 = 12
DEFINES = {"MAX_LAYERS": MAX_LAYERS, "LAYER_VEC4": LAYER_VEC4}


# GLSL per kind; {b} is the layer's first uLayer index, {O} the (slid) eye point.
_CODE = {
    # p0 = (density)
    "homogeneous": "tau += homogeneousOpticalDepth(uLayer[{b}].x, ds);",
    # p0 = (density, falloff, base)
    "height": "tau += heightOpticalDepth({O}, w, ds, uLayer[{b}].x, uLayer[{b}].y, uLayer[{b}].z);",
    # p0 = (axis, offset); p1 = (density, C, repeat, period); p2, p3 coefficients; p4, p5 Q
    "polynomial": "tau += uLayer[{b1}].x * polynomialOpticalDepth({O}, w, ds, uLayer[{b}].xyz, "
                  "uLayer[{b}].w, uLayer[{b1}].y, uLayer[{b1}].z > 0.5, uLayer[{b1}].w, "
                  "uLayer[{b2}], uLayer[{b3}], uLayer[{b4}], uLayer[{b5}]);",
    # p0 = (center, strength); p1 = (unit axis or 0, c); p2.x = e
    "potential": "tau += potentialOpticalDepth({O}, w, ds, uLayer[{b}].xyz, uLayer[{b1}].xyz, "
                 "uLayer[{b}].w, uLayer[{b1}].w, uLayer[{b2}].x);",
    # p0 = (center, radius); p1.x = density
    "sphere": "tau += sphereOpticalDepth({O}, w, ds, uLayer[{b}].xyz, uLayer[{b}].w, uLayer[{b1}].x);",
    # p0 = (alpha, radius, first particle, count)
    "particles": "for (int j = 0; j < int(uLayer[{b}].w); ++j) {{ "
                 "vec4 q = texelFetch(uParticles, ivec2(int(uLayer[{b}].z) + j, 0), 0); "
                 "T *= particleClarity(Os, w, ds, q.xyz, uLayer[{b}].y, q.w, uLayer[{b}].x); }}",
    # p0 = (density, 1/scale, -, samples); p1 = (falloff flag, 1/falloff scale)
    "noise/surface": "tau += noiseSurfaceOpticalDepth(uNoise, Os, P, P - ({S}), ds, uLayer[{b}].x, "
                     "uLayer[{b}].y, uLayer[{b1}].x > 0.5, uLayer[{b1}].y);",
    "noise/volume": "tau += noiseVolumeOpticalDepth(uNoise, {O}, w, ds, uLayer[{b}].x, uLayer[{b}].y, "
                    "int(uLayer[{b}].w));",
    # p0 = (start, 1/D, exponent, max); p1 = (low, high, 1/noise scale)
    "distance": "T *= distanceTransmittance(ds, noiseSample(uNoise, P - ({S}), uLayer[{b1}].z), "
                "uLayer[{b}].x, uLayer[{b}].y, uLayer[{b}].z, uLayer[{b}].w, uLayer[{b1}].x, "
                "uLayer[{b1}].y);",
}


def variant(fog: FogParams) -> tuple:
    """What the generated GLSL depends on: per enabled layer, its kind (with the noise
    mode), its wind flag, and its number of cosine terms. Particle layers keep their
    slot (their data is packed there) whether or not the shader loops over them."""
    key = []
    for layer in fog.layers:
        if not layer.enabled:
            continue
        kind = f"noise/{layer.mode}" if isinstance(layer, Noise) else layer.kind
        terms = len(layer.terms) if isinstance(layer, Cosine) else 0
        key.append((kind, layer.wind, terms))
    return tuple(key)


def layer_code(key: tuple, inline_particles: bool = True) -> str:
    """The body of fog/layers.gen.glsl for a variant key. With inline_particles False,
    particle layers are left to the particle quads pass (passes/particles.*)."""
    lines = []
    for i, (kind, wind, terms) in enumerate(key):
        if kind == "particles" and not inline_particles:
            lines.append(f"// layer {i}: particles, drawn as quads")
            continue
        b = i * LAYER_VEC4
        S = "slide" if wind else "vec3(0.0)"
        O = "(Os - slide)" if wind else "Os"
        idx = {f"b{k}": b + k for k in range(1, LAYER_VEC4)}
        lines.append(f"// layer {i}: {kind}{' (wind)' if wind else ''}")
        if kind == "cosine":
            # p0 = (density, c0, 1/scale, -); uLayer[b+1+j] = (k_j, phase_j); amps at b+9, b+10
            body = [f"float acc = uLayer[{b}].y * ds;", f"vec3 Ou = {O} * uLayer[{b}].z;",
                    f"vec3 wu = w * uLayer[{b}].z;"]
            for j in range(terms):
                body.append(f"acc += cosineTermOpticalDepth(Ou, wu, ds, uLayer[{b + 1 + j}].xyz, "
                            f"uLayer[{b + 1 + j}].w, uLayer[{b + 9 + j // 4}][{j % 4}]);")
            body.append(f"tau += uLayer[{b}].x * acc;")
            lines.append("{ " + " ".join(body) + " }")
        else:
            lines.append(_CODE[kind].format(b=b, O=O, S=S, **idx))
    return "\n".join(lines) + "\n"


# The density at x of each exponential kind, for the raymarched comparison ({X}: x slid).
_DENSITY = {
    "homogeneous": "rho += homogeneousDensity(uLayer[{b}].x);",
    "height": "rho += heightDensity({X}, uLayer[{b}].x, uLayer[{b}].y, uLayer[{b}].z);",
    "polynomial": "rho += uLayer[{b1}].x * polynomialDensity({X}, uLayer[{b}].xyz, uLayer[{b}].w, "
                  "uLayer[{b1}].y, uLayer[{b1}].z > 0.5, uLayer[{b2}], uLayer[{b3}]);",
    "potential": "rho += potentialDensity({X}, uLayer[{b}].xyz, uLayer[{b1}].xyz, uLayer[{b}].w, "
                 "uLayer[{b1}].w, uLayer[{b2}].x);",
    "sphere": "rho += sphereDensity({X}, uLayer[{b}].xyz, uLayer[{b}].w, uLayer[{b1}].x);",
}


def density_code(key: tuple) -> str:
    """The body of fog/density.gen.glsl (used only when RAYMARCH_STEPS is defined): the
    summed density at x of the exponential layers in `key`."""
    lines = []
    for i, (kind, wind, terms) in enumerate(key):
        b = i * LAYER_VEC4
        X = "(x - slide)" if wind else "x"
        idx = {f"b{k}": b + k for k in range(1, LAYER_VEC4)}
        if kind == "cosine":
            t = " + ".join(f"cosineTermDensity({X} * uLayer[{b}].z, uLayer[{b + 1 + j}].xyz, "
                           f"uLayer[{b + 1 + j}].w, uLayer[{b + 9 + j // 4}][{j % 4}])"
                           for j in range(terms)) or "0.0"
            lines.append(f"rho += uLayer[{b}].x * (uLayer[{b}].y + {t});")
        elif kind in _DENSITY:
            lines.append(_DENSITY[kind].format(b=b, X=X, **idx))
        else:
            lines.append(f"// layer {i}: {kind} has no raymarched form")
    return "\n".join(lines) + "\n"


def pack(fog: FogParams, particle_states: dict[int, tuple[np.ndarray, np.ndarray]]):
    """Returns (uLayer data float32 (MAX_LAYERS*LAYER_VEC4, 4), particles float32
    (MAX_PARTICLES, 4)) for the enabled layers, in the order of `variant(fog)`."""
    data = np.zeros((MAX_LAYERS * LAYER_VEC4, 4), np.float64)
    parts = np.zeros((MAX_PARTICLES, 4), np.float64)
    n = 0
    first = 0
    for i, layer in enumerate(fog.layers):
        if not layer.enabled:
            continue
        v = data[n * LAYER_VEC4:(n + 1) * LAYER_VEC4]
        if isinstance(layer, Homogeneous):
            v[0, 0] = layer.density
        elif isinstance(layer, Height):
            v[0, :3] = (layer.density, layer.falloff, layer.base)
        elif isinstance(layer, Cosine):
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
            v[0] = (layer.alpha, layer.radius, first, count)
            first += count
        elif isinstance(layer, Noise):
            v[0] = (layer.density, 1.0 / layer.scale, 1.0 if layer.mode == "volume" else 0.0,
                    layer.samples)
            v[1, :2] = (1.0 if layer.height_falloff else 0.0, 1.0 / layer.falloff_scale)
        elif isinstance(layer, Distance):
            v[0] = (layer.start, 1.0 / layer.distance, layer.exponent, layer.max)
            v[1, :3] = (layer.low, layer.high, 1.0 / layer.noise_scale)
        n += 1
    return data.astype(np.float32), parts.astype(np.float32)
