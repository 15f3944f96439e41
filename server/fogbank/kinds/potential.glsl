#include "common/math.glsl"

// Biri 2002, 3.2.3, eq. 9: density a / (c + e r^2), r the distance from x to a point
// (axis = 0) or to the infinite line through `center` along the unit `axis`.
// In the plane across the axis, with q = center - O and the ray's direction wp (length m):
// r^2(s) = (m s - b)^2 + h^2, b = q . wn, h = |q x wn| (wn = wp / m: the closest approach,
// h from a cross product, never from |q|^2 - b^2, which cancels when the centre is far).
// The integral is a d / K * (atan x1 - atan x0) / (x1 - x0), K = c + e h^2,
// x = sqrt(e / K) (m s - b), written with atan2(x1 - x0, 1 + x0 x1) so that m -> 0 (a ray
// along the line) stays exact. a in 1/m, c unitless, e in 1/m^2, positions in m.
float potentialOpticalDepth(vec3 O, vec3 w, float d, vec3 center, vec3 axis,
                            float a, float c, float e) {
    vec3 q = center - O;
    q -= dot(q, axis) * axis;
    vec3 wp = w - dot(w, axis) * axis;
    float m = length(wp);
    float b = 0.0;
    float h2 = dot(q, q);
    // m == 0 only for a ray exactly along the line: every point is |q| from it (b = 0)
    if (m > 0.0) {
        vec3 wn = wp / m;
        b = dot(q, wn);
        vec3 x = cross(q, wn);
        h2 = dot(x, x);
    }
    float K = c + e * h2;
    float s = sqrt(e / K);
    float x0 = -s * b;
    float x1 = s * (m * d - b);
    return a * d / K * atanRatio(s * m * d, 1.0 + x0 * x1);
}

// Its density a / (c + e r^2) at x, for the raymarched comparison.
float potentialDensity(vec3 x, vec3 center, vec3 axis, float a, float c, float e) {
    vec3 q = x - center;
    q -= dot(q, axis) * axis;
    return a / (c + e * dot(q, q));
}
