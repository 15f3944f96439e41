// IEC 61966-2-1 sRGB transfer function, linear light in [0, 1] -> encoded [0, 1].
vec3 linearToSrgb(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
}

// The 8-bit output: sRGB-encoded, dithered by up to half a level either way with
// interleaved gradient noise at the pixel px (common/dither.glsl), so that smooth
// gradients (the sky round the sun) average to their true value instead of banding into
// 1-level rings.
#include "common/dither.glsl"
vec3 outputColor(vec3 linear, vec2 px) {
    return linearToSrgb(linear) + (interleavedGradientNoise(px) - 0.5) / 255.0;
}
