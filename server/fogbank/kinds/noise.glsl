#include "common/noise_texture.glsl"

// Surface mode (the write-up): tau = rho d n at the visible point P, with the quadratic
// height falloff n dY^2 / 2 + 0.001, dY = (O_y - P_y) / falloffScale (unitless).
float noiseSurfaceOpticalDepth(sampler3D tex, vec3 O, vec3 P, float d, float rho,
                               float invScale, vec3 off, bool falloff, float invFalloffScale) {
    float n = noiseSample(tex, P, invScale, off, true);
    if (falloff) {
        float dy = (O.y - P.y) * invFalloffScale;
        n = n * dy * dy * 0.5 + 0.001;
    }
    return rho * d * n;
}

// The stated error of the volume mode, in optical depth, that the sample count aims for.
const float NOISE_TOL = 1e-3;

// Samples the volume mode takes on a ray: its error bound (see below) brought under
// NOISE_TOL, within [1, maxSamples]. L = N invScale (|w| . D) bounds |dn/ds| along the ray:
// n is trilinear, so each partial derivative is at most the largest step between
// neighbouring texels along that axis (D, measured when the noise is baked).
int noiseVolumeSamples(float d, float rho, float N, float invScale, vec3 w, vec3 D, int maxSamples,
                       float jitter) {
    float L = N * invScale * dot(abs(w), D);
    float need = ceil(rho * L * d * d * (jitter * jitter + (1.0 - jitter) * (1.0 - jitter)) / (2.0 * NOISE_TOL));
    return int(clamp(need, 1.0, float(maxSamples)));
}

// Volume mode (beyond the write-up): rho times the integral of n along the ray by S
// points, each at the share `jitter` of its interval of length h (0.5: the midpoint
// rule; a frame gives each pixel its own, deterministic, so that a sample count too low
// for the noise shows as fine grain, not as the bands of fixed slices). A point at
// jitter j errs over its interval by at most L h^2 (j^2 + (1 - j)^2) / 2
// (|n(s) - n(s_i)| <= L |s - s_i|), so the optical depth by at most
// rho L d^2 (j^2 + (1 - j)^2) / (2 S): rho L d^2 / (4 S) at the midpoint.
float noiseVolumeOpticalDepth(sampler3D tex, vec3 O, vec3 w, float d, float rho,
                              float invScale, vec3 off, vec3 D, int maxSamples, float jitter) {
    int n = noiseVolumeSamples(d, rho, float(textureSize(tex, 0).x), invScale, w, D, maxSamples, jitter);
    float acc = 0.0;
    for (int i = 0; i < n; ++i) {
        acc += noiseSample(tex, O + w * (d * (float(i) + jitter) / float(n)), invScale, off, false);
    }
    return rho * acc * d / float(n);
}
