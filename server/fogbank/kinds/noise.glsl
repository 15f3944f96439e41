#include "common/noise_texture.glsl"

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
