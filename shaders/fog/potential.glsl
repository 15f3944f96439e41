#include "common/math.glsl"

// Biri 2002, 3.2.3, eq. 9: density a / (c + e r^2), r the distance from x to a point
// (axis = 0) or to the infinite line through `center` along the unit `axis`.
// Along O + w s: r^2 = (m s + b)^2 + h^2, m = |w_perp|, so the integral is
// a / (m sqrt(e K)) [atan(x1) - atan(x0)], K = c + e h^2, x = sqrt(e / K) (b + m s).
// Written as a d / K * atan2(y, 1 + x0 x1) / y, y = x1 - x0, it stays exact as m -> 0
// (a ray along the line). a in 1/m, c unitless, e in 1/m^2.
float potentialOpticalDepth(vec3 O, vec3 w, float d, vec3 center, vec3 axis,
                            float a, float c, float e) {
    vec3 q = O - center;
    q -= dot(q, axis) * axis;
    vec3 wp = w - dot(w, axis) * axis;
    float m = length(wp);
    // m == 0 only for a ray exactly along the line; then b is irrelevant (y = 0)
    float b = m > 0.0 ? dot(q, wp) / m : 0.0;
    float h2 = max(dot(q, q) - b * b, 0.0);
    float K = c + e * h2;
    float s = sqrt(e / K);
    float x0 = s * b;
    float x1 = s * (b + m * d);
    return a * d / K * atanRatio(s * m * d, 1.0 + x0 * x1);
}

// Its density a / (c + e r^2) at x, for the raymarched comparison.
float potentialDensity(vec3 x, vec3 center, vec3 axis, float a, float c, float e) {
    vec3 q = x - center;
    q -= dot(q, axis) * axis;
    return a / (c + e * dot(q, q));
}
