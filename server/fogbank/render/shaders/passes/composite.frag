// Composite (Biri eq. 5): C = T C_scene + (1 - T) C_fog, with C_fog tinted by sun
// in-scattering (Gawron 3.2) and, optionally, the fog blur fused in (Gawron 3.4, single
// pass: the scene under the fog is blurred with a Gaussian whose sigma follows 1 - T,
// 5x5 taps on the scene colour's mip pyramid, so that no tap gap shows as a ghost).
// T comes from the fog target, upsampled with depth awareness when it is smaller. With
// MSAA a pixel can hold two surfaces (passes/resolve.frag): each is fogged at its own
// distance and the two are mixed by coverage, so a silhouette gets no outline.
// Defined by the renderer: FOG_SCALE (1, 2, 4), BLUR_MODE (0 off, 1 fused here,
// 2 separate passes follow), SUN_LIGHT (1: the G-buffer has the direct sunlight, to be
// dimmed by the fog toward the sun), TWO_SURFACES (0: every pixel's near surface;
// 1: a second draw that redoes the pixels with a far surface, both mixed), HELD_NEAR
// (1: the near surface from the held composite's inputs, render/passes/composite.py) and
// COMPACT (1, with both: over a target that lists the two-surface pixels, FAR_LIST_WIDTH a
// row, render/targets.py HeldFog.far_pixels; passes/far_scatter.frag puts them in place).
// packHalf2x16 / unpackHalf2x16 (core from GLSL 4.20): the held inputs' AB
#extension GL_ARB_shading_language_packing : require
#include "common/camera.glsl"
#include "common/srgb.glsl"
#include "fog/finish.glsl"
#include "passes/composite_parts.glsl"
#if HELD_NEAR
#include "passes/composite_held.glsl"
#endif
in vec2 vUV;
uniform sampler2D uColor;         // scene colour, linear (mipmapped when blurring: bilinear in the nearest level)
uniform sampler2D uSunLight;      // the direct sunlight in the scene colour, linear
uniform sampler2D uFarColor;      // the pixel's far surface colour, linear; a: the near surface's coverage
uniform sampler2D uFarInvDist;    // its 1/distance
uniform sampler2D uFarSunLight;   // its direct sunlight, linear
uniform float uBlurSigma;         // px at full fog
uniform float uBlurExponent;
#if COMPACT
uniform isampler2D uFarList;      // the two-surface pixels' coordinates (its padding repeats the last)
#endif
layout(location = 0) out vec4 fColor;

// Gawron Table 1: the 5x5 Gaussian kernel with sigma = 1 (weights sum to ~1).
const float K5[5] = float[5](0.054488685, 0.244201342, 0.402619947, 0.244201342, 0.054488685);

// The fused blur of the scene at px with Gaussian sigma (px). Gawron's 5x5 kernel with its
// taps s apart covers a Gaussian of sigma s, but on the full-resolution image the gaps
// between taps show as five ghost copies of a sharp edge once s is a few pixels. Each tap
// reads, bilinearly, the mip level nearest to texels s wide (log2 s rounded: texels from
// s/1.4 to 1.4 s): a box-and-tent prefilter of sigma ~s/2 that closes the gaps. The two
// combine to about sigma^2 = s^2 (1 + 1/4), so s = sigma / sqrt(1.25). Taps on a surface far (> ~5%) from the centre's in depth count
// less, so a near object does not bleed into the fog behind it, nor the reverse.
vec3 blurredScene(ivec2 px, float sigma, float invd, float sunLoss, vec2 full, vec3 own) {
    float s = sigma * 0.894427191;
    float lod = max(log2(s), 0.0);
    vec3 acc = vec3(0.0);
    float wsum = 0.0;
    ivec2 size = ivec2(full);
    for (int y = 0; y < 5; ++y) {
        for (int x = 0; x < 5; ++x) {
            vec2 off = vec2(x - 2, y - 2) * s;
            vec2 uv = (vec2(px) + 0.5 + off) / full;
            float tinvd = texelFetch(uInvDist, clamp(px + ivec2(round(off)), ivec2(0), size - 1), 0).r;
            // relative depth difference; 1e-6 1/m keeps sky-vs-sky at 0 (as fogT)
            float rel = abs(tinvd - invd) / max(max(tinvd, invd), 1e-6);
            float w = K5[x] * K5[y] * exp(-rel * rel * 400.0);
            vec3 tap = textureLod(uColor, uv, lod).rgb;
#if SUN_LIGHT
            tap -= sunLoss * textureLod(uSunLight, uv, lod).rgb;
#endif
            acc += w * tap;
            wsum += w;
        }
    }
    // a far surface seen in a sliver of this pixel may have no tap at its depth (the
    // weights of the others underflow to 0): its own colour, unblurred
    return wsum > 1e-6 ? acc / wsum : own;
}

// The (raw T, T toward the sun, in-scattered sunlight J) at this pixel: the four texels by their
// weights (at full fog resolution, its own texel).
vec3 fogT(ivec2 px, float invd) {
#if FOG_SCALE == 1
    return texelFetch(uFog, px, 0).rba;
#else
    vec2 f;
    ivec2 i0 = fogQuad(px, f);
    vec4 s[4] = vec4[4](fogTexelOf(i0, 0), fogTexelOf(i0, 1), fogTexelOf(i0, 2), fogTexelOf(i0, 3));
    vec4 w = fogWeights(s, f, invd);
    return w.x * s[0].rba + w.y * s[1].rba + w.z * s[2].rba + w.w * s[3].rba;
#endif
}

// T of a pixel's far surface, which the fog texel under the pixel (its block's nearest
// surface) need not see: the 3x3 fog texels around weighted by closeness in depth and in
// the image, or, with none on this surface, the closest in depth.
vec3 fogTAround(ivec2 px, float invd) {
    ivec2 size = textureSize(uFog, 0);
    vec2 p = (vec2(px) + 0.5) / float(FOG_SCALE) - 0.5;
    ivec2 c = ivec2(round(p));
    vec3 acc = vec3(0.0), bestT = vec3(1.0);
    float wsum = 0.0, best = 1e9;
    for (int y = -1; y <= 1; ++y) {
        for (int x = -1; x <= 1; ++x) {
            ivec2 q = clamp(c + ivec2(x, y), ivec2(0), size - 1);
            vec4 s = texelFetch(uFog, q, 0);
            // as fogT: relative depth difference, 1e-6 1/m keeps sky-vs-sky at 0
            float rel = abs(s.g - invd) / max(max(s.g, invd), 1e-6);
            vec2 dq = vec2(q) - p;
            float w = exp(-dot(dq, dq) - rel * rel * 400.0);
            acc += w * s.rba;
            wsum += w;
            if (rel < best) { best = rel; bestT = s.rba; }
        }
    }
    return wsum > 1e-4 ? acc / wsum : bestT;
}

// One surface of the pixel under the fog: (colour, fog transmittance T). `far` picks how
// its T is found (fogTAround for a far surface).
vec4 fogged(ivec2 px, vec3 scene, vec3 sunlight, float invd, vec3 w, vec2 full, bool far) {
    vec3 Ts = far ? fogTAround(px, invd) : fogT(px, invd);
    float T = fogFinish(Ts.x);
    if (invd <= 0.0) T = 1.0 - uSkyAffect * (1.0 - T);   // the sky: only its share of the fog
    float sunLoss = 1.0 - Ts.y;   // the share of the direct sunlight the fog takes away
    vec3 fog = fogLight(T, Ts.x, Ts.z, scatterLobe(w, invd), fogAmbient(w, invd));
#if SUN_LIGHT
    scene -= sunLoss * sunlight;
#endif
    if (BLUR_MODE == 1) {
        float sigma = uBlurSigma * pow(1.0 - T, uBlurExponent);
        if (sigma > 0.05)   // below 0.05 px the kernel is the identity to 8 bits
            scene = blurredScene(px, sigma, invd, sunLoss, full, scene);
    }
    return vec4(T * scene + fog, T);
}

void main() {
    vec2 full = vec2(textureSize(uColor, 0));
#if COMPACT
    ivec2 px = texelFetch(uFarList, ivec2(gl_FragCoord.xy), 0).xy;
    vec2 uv = (vec2(px) + 0.5) / full;
#else
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec2 uv = vUV;
#endif
#if TWO_SURFACES
    vec4 far = texelFetch(uFarColor, px, 0);
#if !COMPACT
    // The second draw, over the pixels that see two surfaces only (about 1%): the others
    // leave at once. A branch would not do: llvmpipe runs both sides of every branch
    // under a lane mask, so the far surface's work would cost every pixel (the
    // composite took twice as long); a discard that kills every lane ends the shader.
    if (far.a >= 1.0) discard;
#endif
#endif
    vec3 w = viewRay(uv * 2.0 - 1.0, uFwd, uRight, uUp);
#if HELD_NEAR
    vec4 c = heldNear(px);   // over a held fog, its kept inputs (passes/composite_held.glsl)
#else
    vec3 sun = vec3(0.0);
#if SUN_LIGHT
    sun = texelFetch(uSunLight, px, 0).rgb;
#endif
    vec4 c = fogged(px, texelFetch(uColor, px, 0).rgb, sun, texelFetch(uInvDist, px, 0).r, w, full, false);
#endif
#if TWO_SURFACES
    vec3 farSun = vec3(0.0);
#if SUN_LIGHT
    farSun = texelFetch(uFarSunLight, px, 0).rgb;
#endif
    vec4 cf = fogged(px, far.rgb, farSun, texelFetch(uFarInvDist, px, 0).r, w, full, true);
    c = mix(cf, c, far.a);   // the two surfaces by coverage
#endif
    if (BLUR_MODE == 2) fColor = vec4(c.rgb, 1.0 - c.a);     // linear, fog amount for the blur
    else fColor = vec4(outputColor(c.rgb, vec2(px)), 1.0);
}
