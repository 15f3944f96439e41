// Small numeric helpers shared by the fog layers. Float32 throughout.

const float PI = 3.14159265358979;
const float TWO_PI = 6.28318530717959;

// (1 - exp(-x)) / x, with its limit 1 at x = 0. Below |x| < 1e-2 the series is used:
// 1 - exp(-x) loses ~6e-8 absolute to rounding, i.e. >6e-6 relative there; the
// 4-term series errs by x^4/120 < 1e-10. For x >= 0 the value lies in (0, 1].
float expRelNeg(float x) {
    if (abs(x) < 1e-2) return 1.0 - x * (0.5 - x * (1.0 / 6.0 - x / 24.0));
    return (1.0 - exp(-x)) / x;
}

// x reduced to [-pi, pi] (GLSL's sin and cos are specified on [-pi, pi] only). The
// reduction errs by ~6e-8 |x|, the float32 uncertainty that x itself carries.
float wrapAngle(float x) {
    return x - TWO_PI * floor(x / TWO_PI + 0.5);
}

// sin(x) / x with its limit 1 at x = 0 (series below |x| < 1e-3, error x^4/120); the
// sine is taken of x reduced to [-pi, pi].
float sinc(float x) {
    if (abs(x) < 1e-3) return 1.0 - x * x / 6.0;
    return sin(wrapAngle(x)) / x;
}

// atan2(y, x) / y for y >= 0, with its limit 1/x as y -> 0 (needs x > 0 there, which
// holds: x = 1 + x0 x1 <= 0 only when the arctangents span more than y > 2).
float atanRatio(float y, float x) {
    if (y < 1e-4) return (1.0 - (y * y) / (3.0 * x * x)) / x;
    return atan(y, x) / y;
}

// log(1 - x) for x in [0, 1): the series below x < 1e-3 (1 - x would keep only ~1e-4 of
// x's digits there; the 4-term series errs by x^5/5 < 2e-16).
float log1mx(float x) {
    if (x < 1e-3) return -x * (1.0 + x * (0.5 + x * (1.0 / 3.0 + x * 0.25)));
    return log(1.0 - x);
}

// The optical depth -density log(1 - x) of a direct transmittance 1 - x (a particle's
// clarity, distance fog's 1 - F), density > 0. An opaque one (x >= 1, T = 0 whatever the
// density) is 1e30: exp(-1e30) is 0 in float32, and GLSL leaves log(0) undefined.
float directDepth(float x, float density) {
    return x < 1.0 ? -density * log1mx(x) : 1e30;
}
