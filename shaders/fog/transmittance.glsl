// The whole fog's transmittance along one ray: the sum of the exponential layers'
// optical depths, times the direct transmittances of particles, surface noise and
// distance fog, raised to the global density, with start/cutoff/max opacity applied.
// Packing of uLayer (LAYER_VEC4 vec4 per layer) is written by server/fogbank/layers.py.
#include "common/math.glsl"
#include "fog/homogeneous.glsl"
#include "fog/height.glsl"
#include "fog/cosine.glsl"
#include "fog/polynomial.glsl"
#include "fog/potential.glsl"
#include "fog/sphere.glsl"
#include "fog/particles.glsl"
#include "fog/noise.glsl"
#include "fog/distance.glsl"

#define KIND_HOMOGENEOUS 0
#define KIND_HEIGHT 1
#define KIND_COSINE 2
#define KIND_POLYNOMIAL 3
#define KIND_POTENTIAL 4
#define KIND_SPHERE 5
#define KIND_PARTICLES 6
#define KIND_NOISE 7
#define KIND_DISTANCE 8

uniform int uLayerCount;
uniform ivec4 uLayerHead[MAX_LAYERS];               // kind, wind-sensitive, count, unused
uniform vec4 uLayer[MAX_LAYERS * LAYER_VEC4];
uniform vec3 uWind;                                   // m/s
uniform float uStartDistance;                         // m
uniform float uCutoffDistance;                        // m, 0 = off
uniform float uMaxOpacity;
uniform float uDensityPow;                            // global density
uniform sampler2D uParticles;                         // (x, y, z, strength) per particle
uniform sampler3D uNoise;

// O: eye (m), w: unit direction, d: length (m), t: time (s).
float fogTransmittance(vec3 O, vec3 w, float d, float t) {
    if (uCutoffDistance > 0.0 && d > uCutoffDistance) return 1.0;
    vec3 Os = O + w * uStartDistance;                 // the segment begins at the start distance
    float ds = max(d - uStartDistance, 0.0);
    vec3 P = Os + w * ds;
    float tau = 0.0;
    float T = 1.0;
    for (int i = 0; i < uLayerCount; ++i) {
        ivec4 head = uLayerHead[i];
        int base = i * LAYER_VEC4;
        vec3 slide = head.y != 0 ? uWind * t : vec3(0.0);  // rho(x) -> rho(x - w t)
        vec3 O_l = Os - slide;
        vec4 p0 = uLayer[base];
        vec4 p1 = uLayer[base + 1];
        if (head.x == KIND_HOMOGENEOUS) {
            tau += homogeneousOpticalDepth(p0.x, ds);
        } else if (head.x == KIND_HEIGHT) {
            tau += heightOpticalDepth(O_l, w, ds, p0.x, p0.y, p0.z);
        } else if (head.x == KIND_COSINE) {
            // p0 = (density, c0, 1/scale, -); uLayer[base+1+j] = (k, phase); amps at +9, +10
            float acc = p0.y * ds;
            vec3 Ou = O_l * p0.z;
            for (int j = 0; j < head.z; ++j) {
                vec4 kp = uLayer[base + 1 + j];
                float amp = uLayer[base + 9 + j / 4][j % 4];
                acc += cosineTermOpticalDepth(Ou, w * p0.z, ds, kp.xyz, kp.w, amp);
            }
            tau += p0.x * acc;
        } else if (head.x == KIND_POLYNOMIAL) {
            // p0 = (axis, offset); p1 = (density, C, repeat, period); +2,+3 coeffs; +4,+5 Q
            tau += p1.x * polynomialOpticalDepth(O_l, w, ds, p0.xyz, p0.w, p1.y, p1.z > 0.5,
                                                 p1.w, uLayer[base + 2], uLayer[base + 3],
                                                 uLayer[base + 4], uLayer[base + 5]);
        } else if (head.x == KIND_POTENTIAL) {
            // p0 = (center, strength); p1 = (unit axis or 0, c); p2.x = e
            tau += potentialOpticalDepth(O_l, w, ds, p0.xyz, p1.xyz, p0.w, p1.w,
                                         uLayer[base + 2].x);
        } else if (head.x == KIND_SPHERE) {
            tau += sphereOpticalDepth(O_l, w, ds, p0.xyz, p0.w, p1.x);
        } else if (head.x == KIND_PARTICLES) {
            // p0 = (alpha, radius, first index, -); head.z = count
            int first = int(p0.z);
            for (int j = 0; j < head.z; ++j) {
                vec4 q = texelFetch(uParticles, ivec2(first + j, 0), 0);
                T *= particleClarity(Os, w, ds, q.xyz, p0.y, q.w, p0.x);
            }
        } else if (head.x == KIND_NOISE) {
            // p0 = (density, 1/scale, volume, samples); p1 = (falloff, 1/falloff scale)
            if (p0.z > 0.5) {
                tau += noiseVolumeOpticalDepth(uNoise, O_l, w, ds, p0.x, p0.y, int(p0.w));
            } else {
                tau += noiseSurfaceOpticalDepth(uNoise, Os, P, P - slide, ds, p0.x, p0.y,
                                                p1.x > 0.5, p1.y);
            }
        } else if (head.x == KIND_DISTANCE) {
            // p0 = (start, 1/D, exponent, max); p1 = (low, high, 1/noise scale)
            float n = noiseSample(uNoise, P - slide, p1.z);
            T *= distanceTransmittance(ds, n, p0.x, p0.y, p0.z, p0.w, p1.x, p1.y);
        }
    }
    T *= exp(-tau);
    // pow(0, 0) is undefined in GLSL; density 0 means no fog at all
    T = uDensityPow > 0.0 ? pow(T, uDensityPow) : 1.0;
    return max(T, 1.0 - uMaxOpacity);
}
