// IEC 61966-2-1 sRGB transfer function, linear light in [0, 1] -> encoded [0, 1]:
// 12.92 c up to 0.0031308, 1.055 c^(1/2.4) - 0.055 above. The power is a minimax fit in
// c^(1/2), c^(1/4), c^(1/8), c and 1 (three square roots; pow is exp2(log2) on llvmpipe,
// about 1.5 ms more over a 1280x720 frame), its coefficients summing to 1 so that white
// stays 1: within 0.009 of an 8-bit level of the exact curve (3.5e-5), far below the
// output's dither (half a level) and its rounding; tests/gl/test_srgb.py checks it
// against the float64 curve.
vec3 linearToSrgb(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    vec3 s1 = sqrt(c), s2 = sqrt(s1), s3 = sqrt(s2);
    vec3 curve = 0.65066356 * s1 + 0.69528556 * s2 - 0.32360300 * s3 - 0.01940530 * c - 0.00294082;
    return mix(c * 12.92, curve, step(0.0031308, c));
}

// The 8-bit output: exposed and tone mapped (common/tonemap.glsl), sRGB-encoded, dithered by up to half a level either way with
// interleaved gradient noise at the pixel px (common/dither.glsl), so that smooth
// gradients (the sky round the sun) average to their true value instead of banding into
// 1-level rings.
#include "common/dither.glsl"
#include "common/tonemap.glsl"
vec3 outputColor(vec3 linear, vec2 px) {
    return linearToSrgb(toneMap(linear)) + (interleavedGradientNoise(px) - 0.5) / 255.0;
}
