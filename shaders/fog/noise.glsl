// Perlin fog write-up: a baked, tiling fractal-noise texture n(x) in [0, 1].
// Trilinear interpolation is done here with texelFetch rather than by the sampler:
// hardware filtering weights have as few as 8 bits on many GPUs (llvmpipe too), an
// error of up to 1/512 of a texel step that the float64 reference would see.
// x in m, invScale = tiles per metre. Texel centres at (i + 0.5) / N, as in GL.
float noiseSample(sampler3D tex, vec3 x, float invScale) {
    int n = textureSize(tex, 0).x;
    float N = float(n);
    vec3 p = x * invScale * N - 0.5;
    p -= N * floor(p / N);                    // wrap into [0, N) before taking integers
    vec3 f = fract(p);
    ivec3 i0 = ivec3(floor(p)) % n;
    ivec3 i1 = (i0 + 1) % n;                  // both non-negative, so % is well defined
    float c000 = texelFetch(tex, ivec3(i0.x, i0.y, i0.z), 0).r;
    float c100 = texelFetch(tex, ivec3(i1.x, i0.y, i0.z), 0).r;
    float c010 = texelFetch(tex, ivec3(i0.x, i1.y, i0.z), 0).r;
    float c110 = texelFetch(tex, ivec3(i1.x, i1.y, i0.z), 0).r;
    float c001 = texelFetch(tex, ivec3(i0.x, i0.y, i1.z), 0).r;
    float c101 = texelFetch(tex, ivec3(i1.x, i0.y, i1.z), 0).r;
    float c011 = texelFetch(tex, ivec3(i0.x, i1.y, i1.z), 0).r;
    float c111 = texelFetch(tex, ivec3(i1.x, i1.y, i1.z), 0).r;
    return mix(mix(mix(c000, c100, f.x), mix(c010, c110, f.x), f.y),
               mix(mix(c001, c101, f.x), mix(c011, c111, f.x), f.y), f.z);
}

// Surface mode (the write-up): tau = rho d n at the visible point P, with the quadratic
// height falloff n dY^2 / 2 + 0.001, dY = (O_y - P_y) / falloffScale (unitless).
float noiseSurfaceOpticalDepth(sampler3D tex, vec3 O, vec3 P, vec3 Pslid, float d, float rho,
                               float invScale, bool falloff, float invFalloffScale) {
    float n = noiseSample(tex, Pslid, invScale);
    if (falloff) {
        float dy = (O.y - P.y) * invFalloffScale;
        n = n * dy * dy * 0.5 + 0.001;
    }
    return rho * d * n;
}

// Volume mode (beyond the write-up): rho integral of n along the ray by the midpoint rule
// with `samples` points. Oslid is the slid eye point.
float noiseVolumeOpticalDepth(sampler3D tex, vec3 Oslid, vec3 w, float d, float rho,
                              float invScale, int samples) {
    float acc = 0.0;
    for (int i = 0; i < samples; ++i) {
        acc += noiseSample(tex, Oslid + w * (d * (float(i) + 0.5) / float(samples)), invScale);
    }
    return rho * acc * d / float(samples);
}
