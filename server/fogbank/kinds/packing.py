"""Packs a fog's layers into the uniforms of render/shaders/fog/transmittance.glsl, and writes
the GLSL that calls each layer's function (fog/layers.gen.glsl).

One layer is LAYER_VEC4 vec4s of uLayer; `_CODE` below gives each kind's slots. Particle
positions go to a texture. The generated code depends only on `variant(fog)` (the kinds,
their wind flags and term counts), so one compiled program serves every value of the
parameters; the renderer caches programs by that key. Positions, phases and tile offsets
are packed relative to a reference point (the eye) and slid by the wind in float64 here.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
from numpy.polynomial import polynomial as npoly

from fogbank.model.params import (MAX_LAYERS, MAX_PARTICLES, Cosine, Distance, FogParams, Height,
                     Homogeneous, Noise, Particles, Polynomial, Potential, Sphere)

LAYER_VEC4 = 12
DEFINES = {"MAX_LAYERS": MAX_LAYERS, "LAYER_VEC4": LAYER_VEC4}
LOG_ZERO = -1e30   # log of a zero density: exp() of it is 0 in float32


# GLSL per kind; {b} is the layer's first uLayer index. Every position, phase and tile
# offset in uLayer is relative to the reference point E and slid by wind * time already
# (see pack), so the calls take the segment start Os and end P relative to E as they are.
_CODE = {
    # p0 = (density)
    "homogeneous": "tau += homogeneousOpticalDepth(uLayer[{b}].x, ds);",
    # p0 = (log density at E's height, hi and lo, falloff)
    "height": "tau += heightOpticalDepth(Os, w, ds, uLayer[{b}].xy, uLayer[{b}].z);",
    # p0 = (axis, u at E reduced to [-C, C)); p1 = (density, C, repeat, period);
    # p2, p3 coefficients; p4, p5 coefficients / (i + 1); p6, p7 the same about e;
    # p8 = (e - u0, e), e the expansion point (u0, clamped to [-C, C] in zero mode)
    "polynomial": "tau += uLayer[{b1}].x * polynomialOpticalDepth(Os, w, ds, uLayer[{b}].xyz, "
                  "uLayer[{b}].w, uLayer[{b1}].y, uLayer[{b1}].z > 0.5, uLayer[{b1}].w, "
                  "uLayer[{b4}], uLayer[{b5}], uLayer[{b6}], uLayer[{b7}], uLayer[{b8}].xy);",
    # p0 = (center - E, strength); p1 = (unit axis or 0, c); p2.x = e
    "potential": "tau += potentialOpticalDepth(Os, w, ds, uLayer[{b}].xyz, uLayer[{b1}].xyz, "
                 "uLayer[{b}].w, uLayer[{b1}].w, uLayer[{b2}].x);",
    # p0 = (center - E, radius); p1.x = density
    "sphere": "tau += sphereOpticalDepth(Os, w, ds, uLayer[{b}].xyz, uLayer[{b}].w, uLayer[{b1}].x);",
    # p0 = (alpha, radius, first particle, count); particle positions relative to E
    "particles": "for (int j = 0; j < int(uLayer[{b}].w); ++j) {{ "
                 "vec4 q = texelFetch(uParticles, ivec2(int(uLayer[{b}].z) + j, 0), 0); "
                 "tau += directDepth(particleOpacity(Os, w, ds, q.xyz, uLayer[{b}].y, q.w, "
                 "uLayer[{b}].x), uDensity); }}",
    # p0 = (density, 1/scale, -, max samples); p1 = (falloff flag, 1/falloff scale);
    # p2 = E in tiles mod 1; p3 = largest texel steps along x, y, z
    "noise/surface": "tau += noiseSurfaceOpticalDepth(uNoise, Os, P, ds, uLayer[{b}].x, "
                     "uLayer[{b}].y, uLayer[{b2}].xyz, uLayer[{b1}].x > 0.5, uLayer[{b1}].y);",
    "noise/volume": "tau += noiseVolumeOpticalDepth(uNoise, Os, w, ds, uLayer[{b}].x, uLayer[{b}].y, "
                    "uLayer[{b2}].xyz, uLayer[{b3}].xyz, int(uLayer[{b}].w));",
    # p0 = (start, 1/D, exponent, max); p1 = (low, high, 1/noise scale); p2 = E in tiles mod 1
    "distance": "tau += directDepth(distanceFogAmount(ds, noiseSample(uNoise, P, uLayer[{b1}].z, "
                "uLayer[{b2}].xyz), uLayer[{b}].x, uLayer[{b}].y, uLayer[{b}].z, uLayer[{b}].w, "
                "uLayer[{b1}].x, uLayer[{b1}].y), uDensity);",
}


def variant(fog: FogParams) -> tuple:
    """What the generated GLSL depends on: per enabled layer, its kind (with the noise
    mode) and its number of cosine terms (the wind slide is packed, not generated). Particle layers keep their
    slot (their data is packed there) whether or not the shader loops over them."""
    key = []
    for layer in fog.layers:
        if not layer.enabled:
            continue
        kind = f"noise/{layer.mode}" if isinstance(layer, Noise) else layer.kind
        terms = len(layer.terms) if isinstance(layer, Cosine) else 0
        key.append((kind, terms))
    return tuple(key)


def layer_code(key: tuple, inline_particles: bool = True) -> str:
    """The body of fog/layers.gen.glsl for a variant key. With inline_particles False,
    particle layers are left to the particle quads pass (passes/particles.*)."""
    lines = []
    for i, (kind, terms) in enumerate(key):
        if kind == "particles" and not inline_particles:
            lines.append(f"// layer {i}: particles, drawn as quads")
            continue
        b = i * LAYER_VEC4
        idx = {f"b{k}": b + k for k in range(1, LAYER_VEC4)}
        lines.append(f"// layer {i}: {kind}")
        if kind == "cosine":
            # p0 = (density, c0, 1/scale, -); uLayer[b+1+j] = (k_j, phase at E); amps at b+9, b+10
            body = [f"float acc = uLayer[{b}].y * ds;", f"vec3 Ou = Os * uLayer[{b}].z;",
                    f"vec3 wu = w * uLayer[{b}].z;"]
            for j in range(terms):
                body.append(f"acc += cosineTermOpticalDepth(Ou, wu, ds, uLayer[{b + 1 + j}].xyz, "
                            f"uLayer[{b + 1 + j}].w, uLayer[{b + 9 + j // 4}][{j % 4}]);")
            body.append(f"tau += uLayer[{b}].x * acc;")
            lines.append("{ " + " ".join(body) + " }")
        else:
            lines.append(_CODE[kind].format(b=b, **idx))
    return "\n".join(lines) + "\n"


# The density at x of each exponential kind, for the raymarched comparison (x relative to E).
_DENSITY = {
    "homogeneous": "rho += homogeneousDensity(uLayer[{b}].x);",
    "height": "rho += heightDensity(x, uLayer[{b}].xy, uLayer[{b}].z);",
    "polynomial": "rho += uLayer[{b1}].x * polynomialDensity(x, uLayer[{b}].xyz, uLayer[{b}].w, "
                  "uLayer[{b1}].y, uLayer[{b1}].z > 0.5, uLayer[{b2}], uLayer[{b3}]);",
    "potential": "rho += potentialDensity(x, uLayer[{b}].xyz, uLayer[{b1}].xyz, uLayer[{b}].w, "
                 "uLayer[{b1}].w, uLayer[{b2}].x);",
    "sphere": "rho += sphereDensity(x, uLayer[{b}].xyz, uLayer[{b}].w, uLayer[{b1}].x);",
}


def density_code(key: tuple) -> str:
    """The body of fog/density.gen.glsl (used only when RAYMARCH_STEPS is defined): the
    summed density at x of the exponential layers in `key`."""
    lines = []
    for i, (kind, terms) in enumerate(key):
        b = i * LAYER_VEC4
        idx = {f"b{k}": b + k for k in range(1, LAYER_VEC4)}
        if kind == "cosine":
            t = " + ".join(f"cosineTermDensity(x * uLayer[{b}].z, uLayer[{b + 1 + j}].xyz, "
                           f"uLayer[{b + 1 + j}].w, uLayer[{b + 9 + j // 4}][{j % 4}])"
                           for j in range(terms)) or "0.0"
            lines.append(f"rho += uLayer[{b}].x * (uLayer[{b}].y + {t});")
        elif kind in _DENSITY:
            lines.append(_DENSITY[kind].format(b=b, **idx))
        else:
            lines.append(f"// layer {i}: {kind} has no raymarched form")
    return "\n".join(lines) + "\n"


FLT_MIN = float(np.finfo(np.float32).tiny)


def direct_density(fog: FogParams) -> float:
    """uDensity, the weight of the direct transmittances' logarithms (T_j^density =
    exp(density log T_j)): a positive density too small for float32 is sent as its
    smallest normal number (T^tiny is 1 to float32; an opaque T_j = 0 stays 0 whatever
    the density, render/shaders/common/math.glsl directDepth)."""
    return max(fog.density, FLT_MIN) if fog.density > 0 else 0.0


def _wind(layer, fog: FogParams) -> np.ndarray:
    """The velocity a layer's density slides with (DESIGN: a wind-sensitive density
    rho(x) becomes rho(x - wind * time)); 0 for a layer that ignores the wind."""
    return fog.wind.vector() if layer.wind else np.zeros(3)


TWO_PI = Fraction("6.283185307179586476925286766559005768394338798750211641949889184615632812572417997256069650684234136")
EXACT_ABOVE = 1e6   # |value| beyond which float64 (1e-16 relative) would lose 1e-10 of a period


def _linear(k, E, wind, time, scale, offset) -> tuple[float, Fraction | None]:
    """k . (E - wind time) / scale + offset: in float64, and exactly (a Fraction of the
    float64 inputs) when it is large enough for float64's rounding to matter."""
    x = float(np.dot(k, E - wind * time)) / scale + offset
    big = abs(float(np.dot(np.abs(k), np.abs(E) + np.abs(wind) * time))) / scale + abs(offset)
    if big < EXACT_ABOVE:
        return x, None
    F = [Fraction(float(v)) for v in k]
    exact = sum(f * (Fraction(float(e)) - Fraction(float(w)) * Fraction(float(time)))
                for f, e, w in zip(F, E, wind)) / Fraction(float(scale)) + Fraction(float(offset))
    return x, exact


def phase_at(k, E, wind, time, scale, phase) -> float:
    """A cosine term's phase k . (E - wind time) / scale + phase at the reference point,
    reduced to [-pi, pi) (exactly, when it is large: late times, fine waves)."""
    x, exact = _linear(k, E, wind, time, scale, phase)
    if exact is None:
        return float(x - 2 * np.pi * np.floor(x / (2 * np.pi) + 0.5))
    return float(exact - TWO_PI * math.floor(exact / TWO_PI + Fraction(1, 2)))


def coordinate_at(axis, E, wind, time, offset, period, C) -> float:
    """A polynomial's u = axis . (E - wind time) + offset at the reference point; with a
    period (repeat mode), reduced to [-C, C) (exactly, when it is large)."""
    x, exact = _linear(axis, E, wind, time, 1.0, offset)
    if period is None:
        return x
    if exact is None:
        return float(x - period * np.floor((x + C) / period))
    P, Cf = Fraction(float(period)), Fraction(float(C))
    return float(exact - P * math.floor((exact + Cf) / P))


def split(x: float) -> tuple[float, float]:
    """x as float32 hi + lo, hi + lo = x to ~1e-14 relative."""
    hi = float(np.float32(x))
    return hi, float(np.float32(x - hi))


def pack(fog: FogParams, particle_states: dict[int, tuple[np.ndarray, np.ndarray]],
         ref=(0.0, 0.0, 0.0), time: float = 0.0):
    """Returns (uLayer data float32 (MAX_LAYERS*LAYER_VEC4, 4), particles float32
    (MAX_PARTICLES, 4)) for the enabled layers, in the order of `variant(fog)`.

    Everything that depends on where or when is taken here in float64, relative to the
    reference point `ref` (the eye of a frame, the origin of a group of rays) and slid by
    wind * `time`: centres become offsets from ref, phases and tile offsets are reduced to
    one period. The shader then works near 0, where float32 is at its finest, whatever the
    eye's distance from the origin or the time (docs/accuracy.md). The global density
    multiplies every exponential layer's density here (into the logarithm for height fog),
    so that a tiny global density over a huge optical depth is not lost to float32."""
    E = np.asarray(ref, dtype=np.float64)
    g = fog.density   # the global density scales every optical depth: folded in here, in float64
    data = np.zeros((MAX_LAYERS * LAYER_VEC4, 4), np.float64)
    parts = np.zeros((MAX_PARTICLES, 4), np.float64)
    n = 0
    first = 0
    for i, layer in enumerate(fog.layers):
        if not layer.enabled:
            continue
        v = data[n * LAYER_VEC4:(n + 1) * LAYER_VEC4]
        Es = E - _wind(layer, fog) * time   # E in the layer's own (unslid) frame
        if isinstance(layer, Homogeneous):
            v[0, 0] = g * layer.density
        elif isinstance(layer, Height):
            log_rho = np.log(layer.density) + np.log(g) if layer.density > 0 and g > 0 else LOG_ZERO
            v[0, :2] = split(log_rho - layer.falloff * (Es[1] - layer.base))
            v[0, 2] = layer.falloff
        elif isinstance(layer, Cosine):
            v[0, :3] = (g * layer.density, layer.c0, 1.0 / layer.scale)
            for j, t in enumerate(layer.terms):
                v[1 + j] = (*t.k, phase_at(t.k, E, _wind(layer, fog), time, layer.scale, t.phase))
                v[9 + j // 4, j % 4] = t.amp
        elif isinstance(layer, Polynomial):
            C = layer.half_width
            c = np.zeros(8)
            c[:len(layer.coeffs)] = layer.coeffs
            Q = npoly.polyint(c)  # Q[0] = 0, Q[i+1] = c_i / (i + 1)
            period = npoly.polyval(C, Q) - npoly.polyval(-C, Q)
            u0 = coordinate_at(layer.axis, E, _wind(layer, fog), time, layer.offset,
                               2 * C if layer.mode == "repeat" else None, C)
            v[0] = (*layer.axis, u0)
            v[1] = (g * layer.density, C, 1.0 if layer.mode == "repeat" else 0.0, period)
            v[2], v[3] = c[:4], c[4:]
            v[4], v[5] = Q[1:5], Q[5:9]
            # P about the point where the reference is (kept inside [-C, C] in zero mode),
            # so a short ray near a root does not cancel large terms (polynomial.glsl)
            e = min(max(u0, -C), C)
            shifted = taylor_shift(c, e)
            v[6], v[7] = shifted[:4] / np.arange(1, 5), shifted[4:] / np.arange(5, 9)
            v[8, :2] = (e - u0, e)
        elif isinstance(layer, Potential):
            axis = np.zeros(3)
            if layer.shape == "line":
                axis = np.asarray(layer.direction, dtype=np.float64)
                axis /= np.linalg.norm(axis)
            q = np.asarray(layer.center) - Es
            q = q - np.dot(q, axis) * axis   # across the line, here in float64: a centre given
            v[0] = (*q, g * layer.strength)  # far along the line must not cost the shader digits
            v[1] = (*axis, layer.c)
            v[2, 0] = layer.e
        elif isinstance(layer, Sphere):
            v[0] = (*(np.asarray(layer.center) - Es), layer.radius)
            v[1, 0] = g * layer.density
        elif isinstance(layer, Particles):
            pos, strength = particle_states[i]
            count = len(pos)
            parts[first:first + count, :3] = pos - E
            parts[first:first + count, 3] = strength
            v[0] = (layer.alpha, layer.radius, first, count)
            first += count
        elif isinstance(layer, Noise):
            v[0] = (g * layer.density, 1.0 / layer.scale, 1.0 if layer.mode == "volume" else 0.0,
                    layer.samples)
            v[1, :2] = (1.0 if layer.height_falloff else 0.0, 1.0 / layer.falloff_scale)
            v[2, :3] = np.mod(Es / layer.scale, 1.0)
            v[3, :3] = noise_steps(fog.noise)
        elif isinstance(layer, Distance):
            v[0] = (layer.start, 1.0 / layer.distance, layer.exponent, layer.max)
            v[1, :3] = (layer.low, layer.high, 1.0 / layer.noise_scale)
            v[2, :3] = np.mod(Es / layer.noise_scale, 1.0)
        n += 1
    return data.astype(np.float32), parts.astype(np.float32)


def taylor_shift(c: np.ndarray, e: float) -> np.ndarray:
    """Coefficients of P(e + v) in v, from P(u) = sum c_i u^i (float64)."""
    out = np.zeros(len(c))
    for i, ci in enumerate(c):
        for k in range(i + 1):
            out[k] += ci * math.comb(i, k) * e ** (i - k)
    return out


def uses_noise(fog: FogParams) -> bool:
    """Whether an enabled layer samples the baked noise (noise and distance layers)."""
    return any(l.enabled and isinstance(l, (Noise, Distance)) for l in fog.layers)


def noise_steps(bake_params) -> np.ndarray:
    """The largest step between neighbouring texels of the baked noise along x, y, z
    (wrapping): bounds the trilinear noise's slope, for the volume mode's error bound."""
    from fogbank.kinds.noise_bake import steps
    return steps(bake_params.size, bake_params.octaves, bake_params.blur, bake_params.seed)
