// The fog pass (Biri 4.1, 4.2): per texel of the fog target (1/uFogScale of the frame,
// uFogScale = 1, 2 or 4), rebuild the visible point from the
// G-buffer and integrate the fog along eye -> point. Writes the raw transmittance (the
// composite applies global density and max opacity, after the particle quads have
// multiplied theirs in), the inverse distance used, for the depth-aware upsample,
// with SUN_THROUGH_FOG the transmittance from the visible point toward the sun (1 for the
// sky and without it), and the sunlight its fog scatters toward the eye (inScattered;
// with LIGHT_GRID, lit by the light grid).
//
// FOG_STAGE (render/passes/fog.py), for a camera that stays still while time runs:
//   0 (or undefined): the whole fog, as above.
//   1: the layers that do not change with time, as sums that later frames reuse: (tau,
//      1/distance, tau toward the sun, unused) and, with STATIC_DIRECT, tauDirect in a
//      second target.
//   2: every other layer, added to the sums of stage 1 (uHeld, uHeldDirect) before the
//      exponential: the same closed forms over the same segments, so stages 1 + 2 give
//      stage 0's texels up to the float32 rounding of the order of the sums.
#ifndef FOG_STAGE
#define FOG_STAGE 0
#endif
#include "fog/transmittance.glsl"
#include "common/camera.glsl"
#include "passes/fog_texel.glsl"
#include "common/dither.glsl"
in vec2 vUV;
uniform sampler2D uInvDist;       // full-resolution 1/distance (1/m), 0 = sky
uniform vec3 uFwd, uRight, uUp;   // camera basis, right/up scaled by tan(fov/2)
uniform float uSkyDistance;       // m
uniform vec3 uSunDir;             // unit, toward the sun
#if FOG_STAGE == 1
layout(location = 0) out vec4 fOut;  // (tau, 1/distance used, tau toward the sun, 0)
#ifdef STATIC_DIRECT
layout(location = 1) out float fDirect;   // tauDirect
#endif
#else
layout(location = 0) out vec4 fOut;  // (raw T, 1/distance used, T toward the sun, in-scattered sunlight J)
#endif
#if FOG_STAGE == 2
uniform sampler2D uHeld;          // stage 1's (tau, 1/distance, tau toward the sun, 0)
#ifdef STATIC_DIRECT
uniform sampler2D uHeldDirect;    // stage 1's tauDirect
#endif
#endif

#ifdef LIGHT_GRID
#include "fog/light_grid.glsl"
#endif

// The sunlight the fog scatters toward the eye over this texel's view ray, as a share of
// the sun's in-scattering without shadows: J = (1 - T) S, T the texel's raw transmittance
// and S the sunlit share of its in-scattering at its distance d, from the light grid
// (passes/light.frag; without it, S = 1: the fog is lit everywhere). The composite
// multiplies J by the sun's colour and the phase function, and the particle quads add
// their own light over it (passes/particles.frag).
float inScattered(float T, float d) {
#ifdef LIGHT_GRID
    return (1.0 - T) * lightShare((floor(gl_FragCoord.xy) + 0.5) * float(uFogScale), d).x;
#else
    return 1.0 - T;
#endif
}

void main() {
#if FOG_STAGE == 2
    ivec2 q = ivec2(gl_FragCoord.xy);
    vec4 held = texelFetch(uHeld, q, 0);
    FogTexel ft = FogTexel(fogTexelRay(gl_FragCoord.xy, textureSize(uInvDist, 0), uFwd, uRight, uUp), held.g);
#else
    FogTexel ft = fogTexel(gl_FragCoord.xy, uInvDist, uFwd, uRight, uUp);
#endif
    // volume noise's points, jittered per pixel (fog/transmittance.glsl); shifted from the
    // pixel's own noise (the output's dither) so that the two patterns do not line up
    gSampleJitter = interleavedGradientNoise(floor(gl_FragCoord.xy) + vec2(7.0, 13.0));
    float d = ft.invd > 0.0 ? 1.0 / ft.invd : uSkyDistance;
#if FOG_STAGE == 1
    vec2 t = fogViewDepths(vec3(0.0), ft.w, d);
    float sunTau = 0.0;
#ifdef SUN_THROUGH_FOG
    // toward the sun from a surface (the sky's is not used). Integrated for every texel
    // and then picked: llvmpipe runs a branch's body under a lane mask whenever one lane
    // takes it, with each assignment a masked store, which cost more than the sky texels'
    // work saved (the default look's 720p fog pass 13.8 -> 13.1 ms, its held stage 2 4.2
    // -> 3.9 ms, the same texels).
    float surfaceSunTau = fogDepths(ft.w * d, uSunDir, uSkyDistance).x;
    if (ft.invd > 0.0) sunTau = surfaceSunTau;
#endif
    fOut = vec4(t.x, ft.invd, sunTau, 0.0);
#ifdef STATIC_DIRECT
    fDirect = t.y;
#endif
#elif FOG_STAGE == 2
    vec2 t = fogViewDepths(vec3(0.0), ft.w, d) + vec2(held.r, 0.0);
#ifdef STATIC_DIRECT
    t.y += texelFetch(uHeldDirect, q, 0).r;
#endif
    float sunT = 1.0;
#ifdef SUN_THROUGH_FOG
    float surfaceSunT = fogSunFromDepth(fogDepths(ft.w * d, uSunDir, uSkyDistance).x + held.b);
    if (ft.invd > 0.0) sunT = surfaceSunT;   // picked, not branched: as in stage 1
#endif
    float T = fogFromDepths(t, d);
    fOut = vec4(T, ft.invd, sunT, inScattered(T, d));
#else
    float sunT = 1.0;
#ifdef SUN_THROUGH_FOG
    float surfaceSunT = fogSunTransmittance(ft.w * d, uSunDir, uSkyDistance);
    if (ft.invd > 0.0) sunT = surfaceSunT;   // picked, not branched: as in stage 1
#endif
    float T = fogRawTransmittance(vec3(0.0), ft.w, d);
    fOut = vec4(T, ft.invd, sunT, inScattered(T, d));
#endif
}
