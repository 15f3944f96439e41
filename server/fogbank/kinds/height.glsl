#include "common/math.glsl"

// Unreal/Filament height fog, rho exp(-k (y - h0)), integrated along O + w s, s in [0, d]:
//   tau = d rho(y_lo) (1 - exp(-k d |w_y|)) / (k d |w_y|),
// y_lo the lower end of the segment. Factoring out the density at the lower end leaves one
// exponential of the height difference, whose exprel lies in (0, 1]: no overflow, no
// 0 * inf, no cancellation, whatever the heights. The whole is taken as one exponential of
// a sum of logarithms:
//   tau = exp(log rho(0) - k y_lo + log d + log exprel(k d |w_y|)),
// log rho(0) = log rho - k (E_y - h0) at the reference point's height (y = 0 here),
// computed in float64 on the CPU and passed as hi + lo floats. O in m (relative to the
// reference point), w unit, d in m, k in 1/m. rho = 0 comes as a log of -1e30.
float heightOpticalDepth(vec3 O, vec3 w, float d, vec2 logRho0, float k) {
    if (d <= 0.0) return 0.0;
    float yLo = O.y + min(d * w.y, 0.0);
    float e = (logRho0.x - k * yLo) + logRho0.y + log(d) + log(expRelNeg(k * d * abs(w.y)));
    // e^88 is float32's largest exponential; optical depths beyond it give T = 0 all the same
    return exp(min(e, 88.0));
}

// Its density at x (1/m), for the raymarched comparison.
float heightDensity(vec3 x, vec2 logRho0, float k) {
    return exp(min((logRho0.x - k * x.y) + logRho0.y, 88.0));
}
