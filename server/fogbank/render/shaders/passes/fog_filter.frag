// The jittered fog's spatial filter: each fog texel's T, T toward the sun and in-scattered
// light averaged over its 3x3 neighbourhood, weighted by closeness in depth (as the
// composite's upsample). Volume noise puts its points at each pixel's interleaved
// gradient noise, which spreads evenly over any 3x3 block: the mean of a block is a
// nine-times-stratified estimate, so the jitter's grain averages out instead of showing
// (and instead of the bands of fixed points). The in-scattered light is (1 - T) times
// the light grid's share: it carries T's grain. The inverse distance is the texel's own.
uniform sampler2D uFog;           // (raw T, 1/distance, T toward the sun, in-scattered light)
layout(location = 0) out vec4 fOut;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    ivec2 size = textureSize(uFog, 0);
    vec4 c = texelFetch(uFog, p, 0);
    vec3 acc = vec3(0.0);
    float wsum = 0.0;
    for (int y = -1; y <= 1; ++y) {
        for (int x = -1; x <= 1; ++x) {
            vec4 s = texelFetch(uFog, clamp(p + ivec2(x, y), ivec2(0), size - 1), 0);
            // relative depth difference; 1e-6 1/m keeps sky-vs-sky at 0 (as the composite)
            float rel = abs(s.g - c.g) / max(max(s.g, c.g), 1e-6);
            float w = exp(-rel * rel * 400.0);   // the centre weighs 1: wsum >= 1
            acc += w * s.rba;
            wsum += w;
        }
    }
    acc /= wsum;
    fOut = vec4(acc.x, c.g, acc.y, acc.z);
}
