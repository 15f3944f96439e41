// IEC 61966-2-1 sRGB transfer function, linear light in [0, 1] -> encoded [0, 1].
vec3 linearToSrgb(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
}

// The 8-bit output: sRGB-encoded, dithered by up to half a level either way with
// interleaved gradient noise (Jimenez 2014) at the pixel px, so that smooth gradients (the
// sky round the sun) average to their true value instead of banding into 1-level rings.
// The noise depends on the pixel alone: the same look renders the same bytes.
vec3 outputColor(vec3 linear, vec2 px) {
    float n = fract(52.9829189 * fract(dot(px, vec2(0.06711056, 0.00583715))));
    return linearToSrgb(linear) + (n - 0.5) / 255.0;
}
