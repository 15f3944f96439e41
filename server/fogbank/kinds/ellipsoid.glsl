#include "kinds/sphere.glsl"
// Ellipsoid fog: the sphere's profile rho max(0, 1 - r^2) with r^2 = |diag(1/a) R (x - c)|^2
// (Quilez's sphere in the ellipsoid's metric). In that metric the ray O + w s becomes
// O' + w' s with |w'| = m, and the integral over s in [0, d] is exactly (1/m) times the
// unit sphere's closed form along w'/m over the length m d. c in m (relative to the
// renderer's reference point), ax, ay, az the body's unit axes, invA = 1/a (1/m), rho in
// 1/m (negative carves), w unit, d in m.
float ellipsoidOpticalDepth(vec3 O, vec3 w, float d, vec3 c, vec3 ax, vec3 ay, vec3 az,
                            vec3 invA, float rho) {
    vec3 q = O - c;
    vec3 o = vec3(dot(q, ax), dot(q, ay), dot(q, az)) * invA;
    vec3 v = vec3(dot(w, ax), dot(w, ay), dot(w, az)) * invA;
    // m >= min(invA) > 0 for a unit w: radii are at most 1e4 m (params), so m >= 1e-4
    float m = length(v);
    return sphereOpticalDepth(o, v / m, m * d, vec3(0.0), 1.0, rho) / m;
}

// Its density at x (1/m), for the raymarched comparison.
float ellipsoidDensity(vec3 x, vec3 c, vec3 ax, vec3 ay, vec3 az, vec3 invA, float rho) {
    vec3 q = x - c;
    vec3 p = vec3(dot(q, ax), dot(q, ay), dot(q, az)) * invA;
    return rho * max(0.0, 1.0 - dot(p, p));
}
