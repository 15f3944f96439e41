#include "common/math.glsl"

// Unreal/Filament height fog, rho exp(-k (y - h0)) integrated along O + w s, s in [0, d]:
// tau = rho d exp(-k (O_y - h0)) (1 - exp(-k d w_y)) / (k d w_y).
// O in m, w unit, d in m, rho in 1/m, k in 1/m, h0 in m.
float heightOpticalDepth(vec3 O, vec3 w, float d, float rho, float k, float h0) {
    // exponent clamped to +-80: exp overflows float32 near 88, and a huge exp(-k(O_y-h0))
    // times a huge (1-exp(-x))/x would give inf*0 = NaN; T = exp(-tau) is 0 there anyway.
    float e0 = clamp(-k * (O.y - h0), -80.0, 80.0);
    float x = clamp(k * d * w.y, -80.0, 80.0);
    return rho * d * exp(e0) * expRelNeg(x);
}

// Its density at x (1/m), for the raymarched comparison.
float heightDensity(vec3 x, float rho, float k, float h0) {
    return rho * exp(clamp(-k * (x.y - h0), -80.0, 80.0));
}
