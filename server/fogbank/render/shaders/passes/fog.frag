// The fog pass (Biri 4.1, 4.2): per texel of the fog target (1/uFogScale of the frame,
// uFogScale = 1, 2 or 4), rebuild the visible point from the
// G-buffer and integrate the fog along eye -> point. Writes the raw transmittance (the
// composite applies global density and max opacity, after the particle quads have
// multiplied theirs in), the inverse distance used, for the depth-aware upsample, and,
// with SUN_THROUGH_FOG, the transmittance from the visible point toward the sun (1 for the
// sky and without it), and, with SHAFTS, the lit share of the view ray (light shafts).
//
// FOG_STAGE (render/passes/fog.py), for a camera that stays still while time runs:
//   0 (or undefined): the whole fog, as above.
//   1: the layers that do not change with time, as sums that later frames reuse: (tau,
//      1/distance, tau toward the sun, lit share) and, with STATIC_DIRECT, tauDirect in a
//      second target. Only this stage samples the shafts (the lit share depends on the
//      camera, the sun and the scene alone).
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
layout(location = 0) out vec4 fOut;  // (tau, 1/distance used, tau toward the sun, lit share)
#ifdef STATIC_DIRECT
layout(location = 1) out float fDirect;   // tauDirect
#endif
#else
layout(location = 0) out vec4 fOut;  // (raw T, 1/distance used, T toward the sun, lit share)
#endif
#if FOG_STAGE == 2
uniform sampler2D uHeld;          // stage 1's (tau, 1/distance, tau toward the sun, lit share)
#ifdef STATIC_DIRECT
uniform sampler2D uHeldDirect;    // stage 1's tauDirect
#endif
#endif

#ifdef SHAFTS
uniform sampler2DShadow uShadow;  // the sun's depth map (compare: 1 = lit)
uniform mat4 uSunViewProj;        // world -> the sun's clip space
uniform vec3 uEye;                // m, world (the shadow map is in world space)
uniform float uShaftLength;       // m: the view ray is sampled this far at most
uniform float uShadowBiasScale;   // times the full map's bias (render/resources.py ShadowMap.bias_scale)

// Light shafts, SAMPLED (not a closed form): the share of SHAFTS samples along the view
// ray's first uShaftLength metres that the sun lights, each sample's place jittered by the
// pixel's interleaved gradient noise (deterministic, so a URL renders the same shafts).
// Every sample counts the same, whatever the fog before it: an approximation of the
// in-scattering integral, labelled so in the schema and docs/departures.md.
float litShare(vec3 w, float d, vec2 px) {
    float len = min(d, uShaftLength);
    float j = interleavedGradientNoise(px);
    float lit = 0.0;
    // the sun's projection is orthographic (affine), so the ray's points in its [0, 1]
    // map space lie on the segment between the two ends' images
    vec3 q0 = (uSunViewProj * vec4(uEye, 1.0)).xyz * 0.5 + 0.5;
    vec3 q1 = (uSunViewProj * vec4(uEye + w * len, 1.0)).xyz * 0.5 + 0.5;
    for (int i = 0; i < SHAFTS; ++i) {
        vec3 q = mix(q0, q1, (float(i) + j) / float(SHAFTS));
        // outside the map nothing casts a shadow; 0.0015 of depth keeps a sample on a lit
        // surface from shadowing itself (as the scene pass's bias, and as it scaled for a
        // preview's coarser map: uShadowBiasScale)
        bool inside = all(greaterThanEqual(q, vec3(0.0))) && all(lessThanEqual(q, vec3(1.0)));
        lit += inside ? texture(uShadow, vec3(q.xy, q.z - 0.0015 * uShadowBiasScale)) : 1.0;
    }
    return lit / float(SHAFTS);
}
#endif

void main() {
#if FOG_STAGE == 2
    ivec2 q = ivec2(gl_FragCoord.xy);
    vec4 held = texelFetch(uHeld, q, 0);
    FogTexel ft = FogTexel(fogTexelRay(gl_FragCoord.xy, textureSize(uInvDist, 0), uFwd, uRight, uUp), held.g);
#else
    FogTexel ft = fogTexel(gl_FragCoord.xy, uInvDist, uFwd, uRight, uUp);
#endif
    // volume noise's points, jittered per pixel (fog/transmittance.glsl); shifted from the
    // shafts' pixel so the two patterns do not line up
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
    float lit = 1.0;
#ifdef SHAFTS
    lit = litShare(ft.w, d, floor(gl_FragCoord.xy));
#endif
    fOut = vec4(t.x, ft.invd, sunTau, lit);
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
    fOut = vec4(fogFromDepths(t, d), ft.invd, sunT, held.a);
#else
    float sunT = 1.0;
#ifdef SUN_THROUGH_FOG
    float surfaceSunT = fogSunTransmittance(ft.w * d, uSunDir, uSkyDistance);
    if (ft.invd > 0.0) sunT = surfaceSunT;   // picked, not branched: as in stage 1
#endif
    float lit = 1.0;
#ifdef SHAFTS
    lit = litShare(ft.w, d, floor(gl_FragCoord.xy));
#endif
    fOut = vec4(fogRawTransmittance(vec3(0.0), ft.w, d), ft.invd, sunT, lit);
#endif
}
