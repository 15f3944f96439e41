"""An independent float64 truth for one look's transmittance along one ray.

The densities are written out here again from DESIGN.md, not imported from fogbank.kinds,
and each exponential layer's optical depth is integrated numerically with adaptive
quadrature (scipy's QUADPACK), told where the integrand has its features: a sphere's
chord ends, a potential's closest approach and width, the lowest point of a height
layer, a tiled polynomial's tile borders (whole tiles integrated once and counted).
Cosine terms use QUADPACK's oscillatory rule (QAWO) with the phase reduced exactly in
rational arithmetic, so late times and fine waves lose nothing. Volume noise is
integrated exactly: trilinear noise is a cubic between the ray's crossings of the texel
lattice, and Simpson's rule is exact on each such piece.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
from scipy.integrate import quad

TWO_PI = Fraction("6.283185307179586476925286766559005768394338798750211641949889184615632812572417997256069650684234136")


def _q(x) -> Fraction:
    return Fraction(float(x))


def reduced_phase(k, x, scale, phase) -> float:
    """(k . x / scale + phase) mod 2 pi, exactly from the float64 inputs."""
    a = sum(_q(ki) * _q(xi) for ki, xi in zip(k, x)) / _q(scale) + _q(phase)
    return float(a - TWO_PI * math.floor(a / TWO_PI))


def slid(layer, fog, O, time):
    """The ray origin in the layer's own frame: rho(x - v t), v the wind for a
    wind-sensitive layer plus the layer's own drift (the noise kinds)."""
    v = (fog.wind.vector() if layer.wind else np.zeros(3)) + np.asarray(getattr(layer, "drift", (0.0,) * 3))
    return np.asarray(O, dtype=np.float64) - v * time


def _quad(f, a, b, points=()):
    pts = sorted(p for p in set(points) if a < p < b)
    edges = [a] + pts + [b]
    total = 0.0
    for lo, hi in zip(edges[:-1], edges[1:]):
        if hi > lo:
            total += quad(f, lo, hi, limit=500, epsabs=0.0, epsrel=1e-11)[0]
    return total


# ------------------------------------------------------------------ exponential layers


def tau_homogeneous(layer, fog, O, w, d, time):
    return _quad(lambda s: layer.density, 0.0, d)


def tau_height(layer, fog, O, w, d, time):
    """The optical depth's logarithm: it can pass float64's range (e^3000 under the base)."""
    if layer.density == 0 or d == 0:
        return -math.inf
    Os = slid(layer, fog, O, time)
    k = layer.falloff

    def log_rho(s):
        return math.log(layer.density) - k * (Os[1] + s * w[1] - layer.base)

    low = d if w[1] < 0 else 0.0            # the lowest point, where the density peaks
    m = log_rho(low)
    scale = 1.0 / (k * abs(w[1])) if k * abs(w[1]) > 0 else d
    pts = [low + sgn * scale * f for f in (0.1, 1, 3, 10, 30, 100) for sgn in (-1, 1)]
    inner = _quad(lambda s: math.exp(log_rho(s) - m), 0.0, d, pts)
    return m + math.log(inner) if inner > 0 else -math.inf


def tau_cosine(layer, fog, O, w, d, time):
    Os = slid(layer, fog, O, time)
    tau = layer.c0 * d
    for t in layer.terms:
        A = reduced_phase(t.k, Os, layer.scale, t.phase)
        B = float(np.dot(t.k, w)) / layer.scale
        if B == 0:
            tau += t.amp * d * math.cos(A)
            continue
        c = quad(lambda s: 1.0, 0.0, d, weight="cos", wvar=B, limit=500)[0]
        s = quad(lambda s: 1.0, 0.0, d, weight="sin", wvar=B, limit=500)[0]
        tau += t.amp * (math.cos(A) * c - math.sin(A) * s)
    return layer.density * tau


def _poly(layer, u):
    return sum(c * u**i for i, c in enumerate(layer.coeffs))


def tau_polynomial(layer, fog, O, w, d, time):
    Os = slid(layer, fog, O, time)
    C = layer.half_width
    a = layer.axis
    u0q = sum(_q(ai) * _q(xi) for ai, xi in zip(a, Os)) + _q(layer.offset)
    rate = float(np.dot(a, w))
    tiled, mirror = layer.mode != "zero", layer.mode == "mirror"
    if tiled:   # shift u0 by whole periods (two tiles when mirrored, keeping parity), exactly
        period = _q(C) * (4 if mirror else 2)
        u0q -= period * math.floor((u0q + _q(C)) / period)
    u0 = float(u0q)

    def P(u):
        if tiled:
            n = math.floor((u + C) / (2 * C))
            u = u - 2 * C * n
            if mirror and n % 2:    # the odd tiles are reflected
                u = -u
        elif u < -C or u > C:
            return 0.0
        return _poly(layer, u)

    if rate == 0 or d == 0:
        return layer.density * d * P(u0)
    u1 = u0 + rate * d
    lo, hi = min(u0, u1), max(u0, u1)
    if not tiled:
        lo, hi = max(lo, -C), min(hi, C)
        return layer.density * (_quad(P, lo, hi) if hi > lo else 0.0) / abs(rate)
    n0, n1 = math.floor((lo + C) / (2 * C)), math.floor((hi + C) / (2 * C))
    if n0 == n1:
        return layer.density * _quad(P, lo, hi) / abs(rate)
    whole = _quad(lambda u: _poly(layer, u), -C, C)
    total = (_quad(P, lo, (n0 + 0.5) * 2 * C) + (n1 - n0 - 1) * whole
             + _quad(P, (n1 - 0.5) * 2 * C, hi))
    return layer.density * total / abs(rate)


def tau_potential(layer, fog, O, w, d, time):
    Os = slid(layer, fog, O, time)
    c = np.asarray(layer.center, dtype=np.float64)
    if layer.shape == "line":
        u = np.asarray(layer.direction, dtype=np.float64)
        u = u / np.linalg.norm(u)
    else:
        u = np.zeros(3)

    def r2(s):
        v = Os + w * s - c
        v = v - np.dot(v, u) * u
        return float(np.dot(v, v))

    def f(s):
        return layer.strength / (layer.c + layer.e * r2(s))

    wp = w - np.dot(w, u) * u
    m2 = float(np.dot(wp, wp))
    pts = []
    if m2 > 0:
        q = c - Os
        q = q - np.dot(q, u) * u
        s_star = float(np.dot(q, wp)) / m2
        width = math.sqrt((layer.c + layer.e * r2(s_star)) / layer.e / m2)
        pts = [s_star + sgn * width * f_ for f_ in (0, 0.3, 1, 3, 10, 100, 1000) for sgn in (-1, 1)]
    return _quad(f, 0.0, d, pts)


def tau_sphere(layer, fog, O, w, d, time):
    Os = slid(layer, fog, O, time)
    c = np.asarray(layer.center, dtype=np.float64)
    R = layer.radius

    def f(s):
        v = Os + w * s - c
        return layer.density * max(0.0, 1.0 - float(np.dot(v, v)) / R**2)

    q = c - Os
    b = float(np.dot(q, w))
    h2 = float(np.dot(np.cross(q, w), np.cross(q, w)))
    if h2 >= R * R:
        return 0.0
    half = math.sqrt(R * R - h2)
    lo, hi = max(0.0, b - half), min(d, b + half)
    return _quad(f, lo, hi) if hi > lo else 0.0


# ------------------------------------------------------------------ bodies (box, ellipsoid)


def body_frame(layer):
    """x -> x in the body's frame (a tuple of floats): yaw about +y, then pitch about the
    body's x, then roll about its z (intrinsic Y-X'-Z''), the rotation written here with
    scipy's rotations, applied in plain floats (it runs millions of times a suite)."""
    from scipy.spatial.transform import Rotation
    rot = Rotation.from_euler("YXZ", [layer.yaw, layer.pitch, layer.roll], degrees=True)
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = rot.inv().as_matrix().tolist()
    cx, cy, cz = (float(v) for v in layer.center)

    def frame(x):
        x0, x1, x2 = float(x[0]) - cx, float(x[1]) - cy, float(x[2]) - cz
        return (m00 * x0 + m01 * x1 + m02 * x2, m10 * x0 + m11 * x1 + m12 * x2,
                m20 * x0 + m21 * x1 + m22 * x2)
    return frame


def body_level(layer, inset: float = 0.0):
    """x -> < 0 inside the body, > 0 outside; convex along any line (the box's largest
    excess over a half extent, the ellipsoid's r^2 - 1). `inset`: the box's half extents
    less that (m), the ellipsoid's r^2 level less that (a nested body: a shell or a fade)."""
    frame = body_frame(layer)
    if layer.kind == "box":
        h0, h1, h2 = (float(v) - inset for v in layer.half_size)

        def box(x):
            p0, p1, p2 = frame(x)
            return max(abs(p0) - h0, abs(p1) - h1, abs(p2) - h2)
        return box
    a0, a1, a2 = (float(v) for v in layer.radii)

    def ellipsoid(x):
        p0, p1, p2 = frame(x)
        return (p0 / a0) ** 2 + (p1 / a1) ** 2 + (p2 / a2) ** 2 - 1.0 + inset
    return ellipsoid


def _resolved(a: float, b: float) -> bool:
    """The bracket [a, b] is as narrow as float64 can hold it (no further step moves it)."""
    return abs(b - a) <= 4e-16 * max(1.0, abs(a), abs(b))


def body_crossings(layer, O, w, d, iters=120, inset: float = 0.0) -> list[float]:
    """Where O + w s, s in [0, d], enters and leaves the body (O in the body's unslid
    frame): the convex level's minimum by golden sections, then its zeros by bisection,
    each until float64 resolves its bracket (at most `iters` steps)."""
    o0, o1, o2 = (float(v) for v in O)
    w0, w1, w2 = (float(v) for v in w)
    level = body_level(layer, inset)

    def f(s):
        return level((o0 + w0 * s, o1 + w1 * s, o2 + w2 * s))

    lo, hi, g = 0.0, float(d), (math.sqrt(5) - 1) / 2
    for _ in range(iters):
        if _resolved(lo, hi):
            break
        a, b = hi - g * (hi - lo), lo + g * (hi - lo)
        if f(a) <= f(b):
            hi = b
        else:
            lo = a
    m = (lo + hi) / 2
    if f(m) >= 0:
        return []
    out = []
    for a, b in ((0.0, m), (float(d), m)):   # from outside (a) toward the inside (b)
        if f(a) <= 0:
            continue
        for _ in range(iters):
            if _resolved(a, b):
                break
            mid = (a + b) / 2
            a, b = (mid, b) if f(mid) > 0 else (a, mid)
        out.append((a + b) / 2)
    return sorted(out)


def body_chord(layer, Os, w, d, inset: float = 0.0):
    """The segment (a, b) of Os + w s, s in [0, d], inside the (nested) body, or None."""
    level = body_level(layer, inset)
    edges = [0.0] + body_crossings(layer, Os, w, d, inset=inset) + [float(d)]
    inside = [(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a and level(Os + w * (a + b) / 2) <= 0]
    return (inside[0][0], inside[-1][1]) if inside else None


def tau_body(layer, fog, O, w, d, time):
    """A box's or an ellipsoid's optical depth, its fade's kinks as the quadrature's points:
    the box's rho times the product over its axes of clamp((h - |p|) / F, 0, 1) (kinks where
    |p_i| = h_i - F), the ellipsoid's rho min(1, (1 - r^2)_+ / f) (kinks at r^2 = 1 - f). A
    carving body has no density of its own (carved_tau)."""
    if layer.carve > 0:
        return 0.0
    Os = slid(layer, fog, O, time)
    chord = body_chord(layer, Os, w, d)
    if chord is None:
        return 0.0
    a, b = chord
    frame = body_frame(layer)
    if layer.kind == "box":
        h = np.asarray(layer.half_size, dtype=np.float64)
        F = layer.edge_fade * float(h.min())
        if F <= 0:
            return _quad(lambda s: layer.density, a, b)
        p0, p1 = frame(Os + w * a), frame(Os + w * b)   # the frame is affine: p is linear in s
        kinks = []
        for i in range(3):
            dp = (p1[i] - p0[i]) / (b - a) if b > a else 0.0
            for target in (h[i] - F, -(h[i] - F)):
                if dp != 0.0:
                    kinks.append(a + (target - p0[i]) / dp)

        def f(s):
            p = frame(Os + w * s)
            return layer.density * math.prod(min(1.0, max(0.0, (float(h[i]) - abs(p[i])) / F))
                                             for i in range(3))
        return _quad(f, a, b, kinks)
    fade = layer.edge_fade
    inner = body_crossings(layer, Os, w, d, inset=fade) if fade < 1.0 else []
    level = body_level(layer)
    return _quad(lambda s: layer.density * min(1.0, max(0.0, -level(Os + w * s)) / fade), a, b, inner)


def carved_tau(fog, Os, w, ds, time, plain) -> float:
    """What the carving bodies take from the density layers along the segment: each body's
    carve / K times `plain` (the other density layers' optical depth) over each of its K
    nested shells' chords (the whole segment's less the pieces outside the chord), found here by bisection (box: half extents less (k + 1/2) / K of
    the fade depth, K = 4, or 1 without a fade; ellipsoid: r^2 <= 1 - f (k + 1/2) / K, K = 4)."""
    total = 0.0
    for layer in fog.layers:
        if not (layer.enabled and layer.kind in SIGNED and layer.carve > 0):
            continue
        Ob = slid(layer, fog, Os, time)
        if layer.kind == "box":
            F = layer.edge_fade * min(layer.half_size)
            k_all = 4 if F > 0 else 1
            insets = [F * (k + 0.5) / k_all for k in range(k_all)]
        else:
            k_all = 4
            insets = [layer.edge_fade * (k + 0.5) / k_all for k in range(k_all)]
        for inset in insets:
            chord = body_chord(layer, Ob, w, ds, inset)
            if chord is not None:
                # the ray's depth less the pieces outside the chord: the depth over the chord
                # for every layer that integrates, and the stated rule for surface-mode noise
                # (rho times a piece's length times the noise at its own end)
                outside = sum(plain(Os + w * a, w, b - a) for a, b in ((0.0, chord[0]), (chord[1], ds)) if b > a)
                total += layer.carve / k_all * (plain(Os, w, ds) - outside)
    return total


# ------------------------------------------------------------------ noise


def noise_at(tex, x, scale, offset_tiles=None):
    """Trilinear, wrapping lookup of the baked tile at points x (N, 3), texel centres at
    (i + 0.5) / N. Written again here; x in tiles is reduced exactly when it is large."""
    n = tex.shape[0]
    p = np.asarray(x, dtype=np.float64) / scale
    p = (p - np.floor(p)) * n - 0.5
    i0 = np.floor(p).astype(np.int64)
    f = p - i0
    out = np.zeros(len(p))
    for dx in (0, 1):
        for dy in (0, 1):
            for dz in (0, 1):
                wgt = ((f[:, 0] if dx else 1 - f[:, 0]) * (f[:, 1] if dy else 1 - f[:, 1])
                       * (f[:, 2] if dz else 1 - f[:, 2]))
                out += wgt * tex[(i0[:, 0] + dx) % n, (i0[:, 1] + dy) % n, (i0[:, 2] + dz) % n]
    return out


MAX_PIECES = 2_000_000


def noise_line_integral(tex, O, w, d, scale):
    """The exact integral of the trilinear noise along O + w s, s in [0, d], or None when
    the ray crosses more than MAX_PIECES lattice cells. Between crossings of the lattice
    (planes p_i = integer, p = x / scale * N - 1/2) the noise is a cubic in s; Simpson's
    rule on each piece is exact for cubics."""
    n = tex.shape[0]
    if d == 0:
        return 0.0
    p0 = np.asarray(O, dtype=np.float64) / scale * n - 0.5
    dp = np.asarray(w, dtype=np.float64) / scale * n
    cuts = [np.array([0.0, d])]
    count = 0
    for i in range(3):
        if dp[i] == 0:
            continue
        a, b = sorted((p0[i], p0[i] + dp[i] * d))
        k0, k1 = math.floor(a) + 1, math.ceil(b) - 1
        count += max(0, k1 - k0 + 1)
        if count > MAX_PIECES:
            return None
        if k1 >= k0:
            cuts.append((np.arange(k0, k1 + 1) - p0[i]) / dp[i])
    s = np.unique(np.clip(np.concatenate(cuts), 0.0, d))
    lo, hi = s[:-1], s[1:]
    mid = (lo + hi) / 2

    def at(t):
        return noise_at(tex, np.asarray(O)[None, :] + np.asarray(w)[None, :] * t[:, None], scale)

    return float(np.sum((hi - lo) / 6.0 * (at(lo) + 4 * at(mid) + at(hi))))


# ------------------------------------------------------------------ the whole look

EXPONENTIAL = {"homogeneous": tau_homogeneous, "height": tau_height, "cosine": tau_cosine,
               "polynomial": tau_polynomial, "potential": tau_potential, "sphere": tau_sphere}
SIGNED = {"box": tau_body, "ellipsoid": tau_body}   # bodies: a carving one removes fog (carved_tau)


def particle_log_clarity(layer, state, O, w, d):
    """Fischer: the log of the product over particles of 1 - alpha s clamp(1 - dist / R_j, 0, 1),
    dist from each particle to the segment (projected onto the line, clamped to [0, d]);
    summed as logarithms (900 particles of clarity 0.25 multiply to 1e-538, below float64).
    R_j: the radius R at birth, grown linearly with the particle's age a over its life to
    growth R at its end: R (1 + (growth - 1) a)."""
    pos, strength, age = state
    if len(pos) == 0:
        return 0.0
    rel = np.asarray(pos, dtype=np.float64) - O
    u = np.clip(rel @ w, 0.0, d)
    dist = np.linalg.norm(rel - u[:, None] * w[None, :], axis=1)
    R = layer.radius + (layer.growth * layer.radius - layer.radius) * np.asarray(age, dtype=np.float64)
    opacity = layer.alpha * np.asarray(strength) * np.clip(1.0 - dist / R, 0.0, 1.0)
    with np.errstate(divide="ignore"):
        return float(np.sum(np.log1p(-opacity)))


def plain_log_tau(fog, Os, w, ds, time, tex=None):
    """The log of the density layers' optical depth over the segment Os + w s, s in [0,
    ds], carving bodies left out, before the global density (None: a volume noise
    integral out of reach)."""
    P = Os + w * ds
    tau = 0.0
    log_tau = -math.inf   # logs of optical depths that float64 cannot hold (height fog)
    for layer in fog.layers:
        if not layer.enabled:
            continue
        if layer.kind == "height":
            log_tau = np.logaddexp(log_tau, tau_height(layer, fog, Os, w, ds, time))
        elif layer.kind in EXPONENTIAL or layer.kind in SIGNED:
            tau += {**EXPONENTIAL, **SIGNED}[layer.kind](layer, fog, Os, w, ds, time)
        elif layer.kind == "noise":
            if layer.mode == "volume":
                integral = noise_line_integral(tex, slid(layer, fog, Os, time), w, ds, layer.scale)
                if integral is None:
                    return None
                tau += layer.density * integral
            else:
                n = noise_at(tex, slid(layer, fog, P, time)[None, :], layer.scale)[0]
                if layer.height_falloff:
                    dy = (Os[1] - P[1]) / layer.falloff_scale
                    n = n * dy * dy / 2 + 0.001
                tau += layer.density * ds * n
    return float(np.logaddexp(log_tau, math.log(tau) if tau > 0 else -math.inf))


def raw(fog, O, w, d, time, tex=None, states=None):
    """(log of the optical depth of the exponential layers, log of the direct transmittances,
    what the carving bodies take away, <= 0) along the segment after the start distance,
    before the global density: or None where the exact volume-noise integral is out of
    reach (more than MAX_PIECES cells)."""
    O = np.asarray(O, dtype=np.float64)
    w = np.asarray(w, dtype=np.float64)
    e = fog.effects
    Os = O + w * e.start_distance
    ds = max(d - e.start_distance, 0.0)
    P = Os + w * ds
    log_tau = plain_log_tau(fog, Os, w, ds, time, tex)
    if log_tau is None:
        return None

    def plain(o, ww, dd):
        lt = plain_log_tau(fog, o, ww, dd, time, tex)
        return math.exp(min(lt, 700.0)) if lt is not None else 0.0
    signed = -carved_tau(fog, Os, w, ds, time, plain)
    log_direct = 0.0
    for i, layer in enumerate(fog.layers):
        if not layer.enabled or layer.kind in EXPONENTIAL or layer.kind in SIGNED or layer.kind in ("height", "noise"):
            continue
        if layer.kind == "distance":
            n = noise_at(tex, slid(layer, fog, P, time)[None, :], layer.noise_scale)[0]
            N = layer.low + (layer.high - layer.low) * n
            x = max(ds - layer.start, 0.0) / layer.distance
            F = min(max(N * x**layer.exponent, 0.0), layer.max)
            log_direct += math.log(1.0 - F) if F < 1 else -math.inf
        elif layer.kind == "particles":
            log_direct += particle_log_clarity(layer, states[i], Os, w, ds)
        else:
            raise AssertionError(f"no truth for layer kind {layer.kind!r}")
    return log_tau, log_direct, signed


def compose(fog, d, parts):
    """T from raw()'s parts: the global density, the cutoff and the max opacity."""
    e = fog.effects
    if fog.density == 0:
        return 1.0
    if e.cutoff_distance > 0 and d > e.cutoff_distance:   # Biri 4.2: the fog colour; or none
        return max(0.0, 1.0 - e.max_opacity) if e.cutoff_mode == "fog" else 1.0
    log_tau, log_direct, signed = parts
    # the exponential layers' depth less what the carving bodies take (kept at 0 or more:
    # overlapping bodies remove their shares twice); the direct layers are not carved
    x = (max(math.exp(min(math.log(fog.density) + log_tau, 700.0)) + fog.density * signed, 0.0)
         - fog.density * log_direct)
    T = math.exp(-x) if math.isfinite(x) else 0.0
    return max(T, 1.0 - e.max_opacity)


def truth(fog, O, w, d, time, tex=None, states=None):
    """T of the look along one ray (None: see raw)."""
    parts = raw(fog, O, w, d, time, tex, states)
    return None if parts is None else compose(fog, d, parts)


# ------------------------------------------------------------------ the contract

ULP = 2.0**-24          # float32's unit roundoff
RAY_ULPS = 8            # the GPU's ray: within this many float32 roundings of the request


def noise_bound(fog, tex, w, d):
    """The volume noise's stated error bound on T (docs/accuracy.md): the midpoint rule on
    an L-Lipschitz integrand errs by at most rho L d^2 / (4 S) in optical depth, with S the
    samples the shader takes, ceil(rho L d^2 / (4e-3)) within [1, samples]."""
    e = fog.effects
    ds = max(d - e.start_distance, 0.0)
    if e.cutoff_distance > 0 and d > e.cutoff_distance:
        return 0.0
    total = 0.0
    n = tex.shape[0]
    steps = [float(np.abs(np.roll(tex.astype(np.float64), -1, a) - tex).max()) for a in range(3)]
    for layer in fog.layers:
        if layer.enabled and layer.kind == "noise" and layer.mode == "volume":
            rho = fog.density * layer.density
            L = n / layer.scale * float(np.abs(np.asarray(w)) @ np.asarray(steps))
            S = min(max(math.ceil(rho * L * ds * ds / 4e-3), 1), layer.samples)
            total += rho * L * ds * ds / (4.0 * S)
    return min(total, 1.0)


def box_ray(O, w, d, eta, x):
    """The ray of the box around (O, w, d) at x in [-1, 1]^3: its length scaled by
    1 + x[0] eta, its direction turned by x[1] eta and x[2] eta about two axes across it."""
    w = np.asarray(w, dtype=np.float64)
    a = np.cross(w, [1.0, 0.0, 0.0] if abs(w[0]) < 0.9 else [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(w, a)
    v = w + eta * (x[1] * a + x[2] * b)
    return O, v / np.linalg.norm(v), d * (1 + x[0] * eta)


def perturbed(O, w, d, eta, n=9):
    """Rays of the box around this one: its length scaled by 1 - eta, 1 or 1 + eta, and its
    direction turned by n steps from -eta to eta about each of two axes across it; with
    each ray its point x in the box."""
    return [(x, box_ray(O, w, d, eta, x)) for x in
            ((fl, fa, fb) for fl in (-1, 0, 1) for fa in np.linspace(-1, 1, n)
             for fb in np.linspace(-1, 1, n)) if any(x)]


def box_extreme(T, start, sign):
    """The least (sign 1) or greatest (sign -1) of T over the box [-1, 1]^3, searched
    from the grid's best point: a small dense feature can lie between grid points (a
    1 cm particle 36 km out passes 4 mm apart between them, more than its own radius)."""
    from scipy.optimize import minimize
    found = minimize(lambda x: sign * T(x), np.asarray(start, dtype=np.float64),
                     method="Powell", bounds=[(-1.0, 1.0)] * 3,
                     options={"xtol": 1e-4, "ftol": 1e-12, "maxfev": 400})
    return sign * found.fun


def check(fog, O, w, d, time, got, tol, tex=None, states=None):
    """(|dT| against the truth, whether it keeps the contract, why) for one ray: within
    `tol`, plus the volume noise's stated bound; or, where float32 cannot place the ray
    finely enough for that, within `tol` of the exact T of a ray RAY_ULPS float32
    roundings away (the backward error of any float32 renderer: docs/accuracy.md).
    None where the truth is out of reach."""
    want = truth(fog, O, w, d, time, tex, states)
    if want is None:
        return None
    if not (np.isfinite(got) and 0.0 <= got <= 1.0):
        return abs(got - want) if np.isfinite(got) else 1.0, False, "not in [0, 1]"
    err = abs(got - want)
    allowed = tol + (noise_bound(fog, tex, w, d) if tex is not None else 0.0)
    if err <= allowed:
        return err, True, "forward"
    # The box of rays is connected and T is continuous on it (unless the cutoff distance
    # falls inside it, where T jumps), so every value between its least and greatest T is
    # the exact T of some ray in the box; across the cutoff only the values themselves count.
    eta = RAY_ULPS * ULP
    seen = [(x, truth(fog, *ray, time, tex, states), ray[2]) for x, ray in perturbed(O, w, d, eta)]
    seen = [(x, v, l) for x, v, l in seen if v is not None] + [((0, 0, 0), want, d)]
    values = [v for _, v, _ in seen]
    cutoff = fog.effects.cutoff_distance
    if cutoff > 0 and min(l for _, _, l in seen) <= cutoff < max(l for _, _, l in seen):
        if min(abs(got - x) for x in values) <= allowed:
            return err, True, "backward"
        return err, False, "beyond"
    if min(values) - allowed <= got <= max(values) + allowed:
        return err, True, "backward"

    def T(x):
        v = truth(fog, *box_ray(O, w, d, eta, x), time, tex, states)
        return want if v is None else v
    # between the grid's points: the box's own least or greatest T
    sign = 1.0 if got < min(values) else -1.0
    start = min(seen, key=lambda s: sign * s[1])[0]
    if sign * (box_extreme(T, start, sign) - got) <= allowed:
        return err, True, "backward"
    return err, False, "beyond"
