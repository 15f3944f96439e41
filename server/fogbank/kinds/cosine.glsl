#include "common/math.glsl"

// Biri 2002, 3.2.1: one term c cos(k . x + phi) integrated along O + w s, s in [0, d]
// (x in function units: the caller divides positions by the layer's scale):
// integral = c d cos(A + B d / 2) sinc(B d / 2), A = k . O + A0, B = k . w.
// A0 is the term's phase at the reference point (wind slide included), reduced to
// [-pi, pi] in float64 on the CPU, so the phase never carries the eye's distance from the
// origin or the time; the rest is reduced here before cos(), once: the float32 sum of
// k . O, A0 and h errs by about an ulp of the largest, the uncertainty each already
// carries, so reducing each part first gains nothing (and cost 0.6 ms of a 5 ms fog pass
// of four terms on llvmpipe).
float cosineTermOpticalDepth(vec3 O, vec3 w, float d, vec3 k, float A0, float c) {
    float h = 0.5 * dot(k, w) * d;
    return c * d * cos(wrapAngle(dot(k, O) + A0 + h)) * sinc(h);
}

// One term's value c cos(k . x + A0) at x (function units), for the raymarched comparison.
float cosineTermDensity(vec3 x, vec3 k, float A0, float c) {
    return c * cos(wrapAngle(dot(k, x) + A0));
}
