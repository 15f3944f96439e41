// Biri 2002, 3.2.2: P(u) = sum c_i u^i on [-C, C]; outside it the tile is mirrored
// (tiling 2: tile n is P(r) for even n, P(-r) for odd n, r = u - 2Cn: seamless), repeated
// (tiling 1: P(r), which needs P(-C) = P(C)) or zero (tiling 0); u = a . x + b. Integrated along the ray as the tiles it crosses: the partial tile at
// each end and the whole tiles between, each a non-negative amount (P >= 0 on [-C, C]),
// so nothing cancels. A partial piece [u0, u1] inside one tile is (u1 - u0) times the
// mean of P there, sum_i c_i/(i+1) D_i with D_i = (u1^(i+1) - u0^(i+1)) / (u1 - u0)
// = sum_j u0^j u1^(i-j): a sum of products, never a difference of nearby antiderivatives.
// q0, q1 hold c_i / (i+1) for i = 0..7; `period` is the integral over a whole tile.

float polyEval(float u, vec4 c0, vec4 c1) {  // Horner, c0 = coefficients 0..3, c1 = 4..7
    return c0.x + u * (c0.y + u * (c0.z + u * (c0.w + u * (c1.x + u * (c1.y + u * (c1.z + u * c1.w))))));
}

// The mean of P over [u0, u1] (u0 = u1 gives P(u0)).
float polyMean(float u0, float u1, vec4 q0, vec4 q1) {
    float D = 1.0, p = 1.0;                   // D_0 = 1, p = u0^0
    float acc = q0.x;
    p *= u0; D = u1 * D + p; acc += q0.y * D;  // D_i = u1 D_(i-1) + u0^i
    p *= u0; D = u1 * D + p; acc += q0.z * D;
    p *= u0; D = u1 * D + p; acc += q0.w * D;
    p *= u0; D = u1 * D + p; acc += q1.x * D;
    p *= u0; D = u1 * D + p; acc += q1.y * D;
    p *= u0; D = u1 * D + p; acc += q1.z * D;
    p *= u0; D = u1 * D + p; acc += q1.w * D;
    return acc;
}

// Tiled P at u: r in [-C, C) (negated in a mirrored odd tile); 0 outside [-C, C] for zero.
float polyTiled(float u, float C, float tiling, vec4 c0, vec4 c1) {
    if (tiling < 0.5) return (u < -C || u > C) ? 0.0 : polyEval(u, c0, c1);
    float n = floor((u + C) / (2.0 * C));
    float r = u - 2.0 * C * n;
    return polyEval(tiling > 1.5 && mod(n, 2.0) > 0.5 ? -r : r, c0, c1);
}

// The mean of tile n's P over its own [r0, r1] (mirrored: an odd tile is P(-r), whose
// mean over [r0, r1] is P's over [-r1, -r0]).
float polyTileMean(float n, float r0, float r1, bool mirror, vec4 q0, vec4 q1) {
    return mirror && mod(n, 2.0) > 0.5 ? polyMean(-r1, -r0, q0, q1) : polyMean(r0, r1, q0, q1);
}

// tau / density along O + w s, s in [0, d]. u0 is u at the reference point, computed in
// float64 on the CPU and, when tiled, reduced there by whole periods (2C repeated, 4C
// mirrored: into [-C, C) or [-C, 3C), so a tile's parity survives), so it carries neither
// the eye's distance from the origin nor the wind's slide; in zero mode a large u0 is a
// ray far outside the fog's slab. The ray's own u - u0 = a . O + a . w s is taken here.
// A ray within one tile (the usual case, and the one where P can cancel: a short ray near
// a root of a P with large coefficients) is integrated in the tiled P re-expanded about
// e = u0 + ex.x (the coefficients p0, p1 = c'_i / (i+1), shifted in float64 by kinds/polynomial.py;
// e = u0 when tiled, and u0 clamped into [-C, C] in zero mode, passed as ex.y; ex.z is the
// tile the reference lies in, 0 or 1), so its terms are small where the ray is. Rays across
// tiles, or in a mirrored tile of the other parity, use the expansion about 0.
float polynomialOpticalDepth(vec3 O, vec3 w, float d, vec3 a, float u0, float C, float tiling,
                             float period, vec4 q0, vec4 q1, vec4 p0, vec4 p1, vec3 ex) {
    float va = dot(a, O);
    float vb = va + dot(a, w) * d;
    float vlo = min(va, vb), vhi = max(va, vb);          // the ray's u - u0
    float lo = u0 + vlo, hi = u0 + vhi;
    bool mirror = tiling > 1.5;
    if (tiling < 0.5) {
        // clipped in u, where the slab's edges +-C are exact; the mean about the expansion
        // point e = ex.y (= u0 + ex.x), from the ray's own offsets where it ends inside
        float l = max(lo, -C), r = min(hi, C);
        if (r < l) return 0.0;
        bool cl = lo < -C, cr = hi > C;
        float frac = (cl || cr) ? (r - l) / (vhi - vlo) : 1.0;   // share of the ray inside
        float le = cl ? l - ex.y : vlo - ex.x;
        float re = cr ? r - ex.y : vhi - ex.x;
        return d * frac * polyMean(le, re, p0, p1);
    }
    float n0 = floor((lo + C) / (2.0 * C)), n1 = floor((hi + C) / (2.0 * C));
    // the remainders lie in [-C, C); min/max only absorb float32 rounding of huge u
    float r0 = clamp(lo - 2.0 * C * n0, -C, C), r1 = clamp(hi - 2.0 * C * n1, -C, C);
    if (n0 == n1) {
        // tiles an even number away from the reference's hold the same P (any tile when
        // repeated): shifted whole tiles, 0 in the reference's own
        if (!mirror || mod(n0 - ex.z, 2.0) < 0.5) {
            float shift = 2.0 * C * (n0 - ex.z);
            return d * polyMean(vlo - shift, vhi - shift, p0, p1);
        }
        return d * polyTileMean(n0, r0, r1, mirror, q0, q1);
    }
    float whole = (C - r0) * polyTileMean(n0, r0, C, mirror, q0, q1) + (n1 - n0 - 1.0) * period
                + (r1 + C) * polyTileMean(n1, -C, r1, mirror, q0, q1);
    return d * whole / (hi - lo);
}

// P at x (tiled or zero outside), times nothing: the caller weights it by the density.
float polynomialDensity(vec3 x, vec3 a, float u0, float C, float tiling, vec4 c0, vec4 c1) {
    return polyTiled(u0 + dot(a, x), C, tiling, c0, c1);
}
