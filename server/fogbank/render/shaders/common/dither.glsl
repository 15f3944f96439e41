// Interleaved gradient noise (Jimenez 2014, "Next Generation Post Processing in Call of
// Duty: Advanced Warfare"): a value in [0, 1) per pixel px (whole pixel coordinates),
// evenly spread over any small block of pixels. It depends on the pixel alone, so the
// same look renders the same bytes (a URL stays reproducible).
float interleavedGradientNoise(vec2 px) {
    return fract(52.9829189 * fract(dot(px, vec2(0.06711056, 0.00583715))));
}
