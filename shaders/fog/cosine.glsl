#include "common/math.glsl"

// Biri 2002, 3.2.1: one term c cos(k . x + phi) integrated along O + w s, s in [0, d]
// (x in function units: the caller divides positions by the layer's scale):
// integral = c d cos(A + B d / 2) sinc(B d / 2), A = k . O + phi, B = k . w.
float cosineTermOpticalDepth(vec3 O, vec3 w, float d, vec3 k, float phi, float c) {
    float A = dot(k, O) + phi;
    float h = 0.5 * dot(k, w) * d;
    return c * d * cos(A + h) * sinc(h);
}

// One term's value c cos(k . x + phi) at x (function units), for the raymarched comparison.
float cosineTermDensity(vec3 x, vec3 k, float phi, float c) {
    return c * cos(dot(k, x) + phi);
}
