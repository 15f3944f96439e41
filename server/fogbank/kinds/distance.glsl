#include "common/noise_texture.glsl"
// Gawron & Boryczka 2018, eqs. 2, 9, 10 and Listing 1: distance fog amount
// F = clamp(N ((d - start) / D)^e, 0, Fmax), N = lerp(low, high, noise); its transmittance
// is 1 - F (the caller takes -log(1 - F) by directDepth()). d, start, D in m.
float distanceFogAmount(float d, float noise, float start, float invD, float e,
                        float Fmax, float low, float high) {
    float x = max(d - start, 0.0) * invD;
    float N = mix(low, high, noise);
    return clamp(N * pow(x, e), 0.0, Fmax);  // pow(0, e > 0) = 0
}
