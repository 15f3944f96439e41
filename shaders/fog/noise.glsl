// Perlin fog write-up: a baked, tiling fractal-noise texture n(x) in [0, 1].
// Trilinear interpolation is done here with texelFetch rather than by the sampler:
// hardware filtering weights have as few as 8 bits on many GPUs (llvmpipe too), an
// error of up to 1/512 of a texel step that the float64 reference would see.
// x in m (relative to the reference point), invScale = tiles per metre, off = the
// reference point's position in tiles (wind slide included), reduced to [0, 1) in float64
// on the CPU. Texel centres at (i + 0.5) / N, as in GL.
float noiseSample(sampler3D tex, vec3 x, float invScale, vec3 off) {
    int n = textureSize(tex, 0).x;
    float N = float(n);
    vec3 t = x * invScale;
    t -= floor(t);                            // whole tiles first: keeps the sum below small
    vec3 p = fract(t + off) * N - 0.5;
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
float noiseSurfaceOpticalDepth(sampler3D tex, vec3 O, vec3 P, float d, float rho,
                               float invScale, vec3 off, bool falloff, float invFalloffScale) {
    float n = noiseSample(tex, P, invScale, off);
    if (falloff) {
        float dy = (O.y - P.y) * invFalloffScale;
        n = n * dy * dy * 0.5 + 0.001;
    }
    return rho * d * n;
}

// The stated error of the volume mode, in optical depth, that the sample count aims for.
const float NOISE_TOL = 1e-3;

// Samples the volume mode takes on a ray: its error bound rho L d^2 / (4 S) (see below)
// brought under NOISE_TOL, within [1, maxSamples]. L = N invScale (|w| . D) bounds |dn/ds|
// along the ray: n is trilinear, so each partial derivative is at most the largest step
// between neighbouring texels along that axis (D, measured when the noise is baked).
int noiseVolumeSamples(float d, float rho, float N, float invScale, vec3 w, vec3 D, int maxSamples) {
    float L = N * invScale * dot(abs(w), D);
    float need = ceil(rho * L * d * d / (4.0 * NOISE_TOL));
    return int(clamp(need, 1.0, float(maxSamples)));
}

// Volume mode (beyond the write-up): rho times the integral of n along the ray by the
// midpoint rule with S points. Each interval h errs by at most L h^2 / 4 (|n(s) - n(mid)|
// <= L |s - mid|), so the optical depth errs by at most rho L d^2 / (4 S).
float noiseVolumeOpticalDepth(sampler3D tex, vec3 O, vec3 w, float d, float rho,
                              float invScale, vec3 off, vec3 D, int maxSamples) {
    int n = noiseVolumeSamples(d, rho, float(textureSize(tex, 0).x), invScale, w, D, maxSamples);
    float acc = 0.0;
    for (int i = 0; i < n; ++i) {
        acc += noiseSample(tex, O + w * (d * (float(i) + 0.5) / float(n)), invScale, off);
    }
    return rho * acc * d / float(n);
}
