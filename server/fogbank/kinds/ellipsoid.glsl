// Ellipsoid fog (fogbank): the sphere's profile in the ellipsoid's metric, its edge harder
// below f = 1: density rho min(1, max(0, 1 - r^2) / f) with r^2 = |diag(1/a) R (x - c)|^2.
// In that metric the ellipsoid is the unit sphere and the ray O + w s becomes o + v s with
// |v| = m: the integral over s in [0, d] is (1/m) times the unit sphere's along u = v/m
// over the length m d. c in m (relative to the renderer's reference point), ax, ay, az the
// body's unit axes, invA = 1/a (1/m), f in (0, 1], rho in 1/m, w unit, d in m.

// The ray in the metric: (origin, unit direction u), its scale m returned.
float ellipsoidFrame(vec3 O, vec3 w, vec3 c, vec3 ax, vec3 ay, vec3 az, vec3 invA, out vec3 o, out vec3 u) {
    vec3 q = O - c;
    o = vec3(dot(q, ax), dot(q, ay), dot(q, az)) * invA;
    vec3 v = vec3(dot(w, ax), dot(w, ay), dot(w, az)) * invA;
    // m >= min(invA) > 0 for a unit w: radii are at most 1e4 m (params), so m >= 1e-4
    float m = length(v);
    u = v / m;
    return m;
}

// Quilez's 1 - r^2 = a2 - t^2 integrated over [t0, t1], t along u from the closest approach
// to the centre (a2 = 1 - h^2, h the miss distance): the length times the mean.
float unitProfile(float t0, float t1, float a2) {
    return (t1 - t0) * (a2 - (t0 * t0 + t0 * t1 + t1 * t1) / 3.0);
}

float ellipsoidOpticalDepth(vec3 O, vec3 w, float d, vec3 c, vec3 ax, vec3 ay, vec3 az,
                            vec3 invA, float f, float rho) {
    vec3 o, u;
    float m = ellipsoidFrame(O, w, c, ax, ay, az, invA, o, u);
    float b = -dot(o, u);                  // the closest approach's parameter, metric units
    vec3 x = cross(o, u);
    float a2 = 1.0 - dot(x, x);
    if (a2 <= 0.0) return 0.0;             // the line misses (or grazes) the ellipsoid
    float a = sqrt(a2);
    // the chord in t = s - b, clipped to the segment [0, m d]
    float t0 = max(-a, -b), t1 = min(a, m * d - b);
    if (t1 <= t0) return 0.0;
    // inside r^2 <= 1 - f the density is rho: that inner chord's length counts whole, the
    // rest of the chord its profile over f (f = 1: no inner chord, Quilez's profile)
    float ai2 = a2 - f;
    float ti0 = t0, ti1 = t0;              // an empty inner chord
    if (ai2 > 0.0) {
        float ai = sqrt(ai2);
        ti0 = clamp(-ai, t0, t1);
        ti1 = clamp(ai, t0, t1);
    }
    float shell = unitProfile(t0, ti0, a2) + unitProfile(ti1, t1, a2);
    // max(): the profile's mean is >= 0 on the chord; it only absorbs rounding
    return rho * (max(shell, 0.0) / f + (ti1 - ti0)) / m;
}

// A carving ellipsoid's shell k of `shells` (nested ellipsoids at r^2 = 1 - f (k + 1/2) /
// shells; the ellipsoid itself without them): its chord along O + w s, s in [0, d], as
// absolute parameters (s0, s1) (s1 <= s0: none).
vec2 ellipsoidShellChord(vec3 O, vec3 w, float d, vec3 c, vec3 ax, vec3 ay, vec3 az, vec3 invA,
                         float f, int k, int shells) {
    vec3 o, u;
    float m = ellipsoidFrame(O, w, c, ax, ay, az, invA, o, u);
    float r2 = shells > 1 ? 1.0 - f * (float(k) + 0.5) / float(shells) : 1.0;
    float b = -dot(o, u);
    vec3 x = cross(o, u);
    float a2 = r2 - dot(x, x);
    if (a2 <= 0.0) return vec2(1.0, 0.0);
    float a = sqrt(a2);
    // an end clipped to the segment's is the segment's own, exactly (m d / m is not d)
    return vec2(b - a <= 0.0 ? 0.0 : (b - a) / m, b + a >= m * d ? d : (b + a) / m);
}

// Its density at x (1/m), for the raymarched comparison.
float ellipsoidDensity(vec3 x, vec3 c, vec3 ax, vec3 ay, vec3 az, vec3 invA, float f, float rho) {
    vec3 q = x - c;
    vec3 p = vec3(dot(q, ax), dot(q, ay), dot(q, az)) * invA;
    return rho * min(1.0, max(0.0, 1.0 - dot(p, p)) / f);
}

// A carving ellipsoid's share of the fog it removes at x (in [0, 1], times its strength):
// the share of its shells (ellipsoidShellChord) that hold x, for the raymarched comparison.
float ellipsoidCarveShare(vec3 x, vec3 c, vec3 ax, vec3 ay, vec3 az, vec3 invA, float f) {
    vec3 q = x - c;
    vec3 p = vec3(dot(q, ax), dot(q, ay), dot(q, az)) * invA;
    float n = 0.0;
    for (int k = 0; k < CARVE_SHELLS; ++k)
        n += float(dot(p, p) <= 1.0 - f * (float(k) + 0.5) / float(CARVE_SHELLS));
    return n / float(CARVE_SHELLS);
}
