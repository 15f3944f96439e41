// What the composites share (passes/composite.frag, composite_held.frag and
// composite_inputs.frag): the fog target's depth-aware upsample, the in-scattering lobe and
// the fog's light.
// Defined by the renderer: FOG_SCALE (1, 2, 4), AERIAL (0 or 1).
#ifndef AERIAL
#define AERIAL 0
#endif
#include "common/camera.glsl"
#include "common/phase.glsl"
#include "common/sky.glsl"
uniform sampler2D uFog;           // (raw T, 1/distance, T toward the sun, in-scattered sunlight J) at 1/FOG_SCALE size
uniform sampler2D uInvDist;       // full-resolution 1/distance (1/m), 0 = sky
uniform vec3 uFwd, uRight, uUp;   // camera basis, right/up scaled by tan(fov/2)
uniform vec3 uSunDir;             // unit, toward the sun
uniform float uScatterExponent;
uniform float uScatterStart;      // m, Gawron's ScatterStartDist (eq. 5); 0 = the view ray
uniform bool uPhaseHG;            // the lobe: Henyey-Greenstein (true) or Gawron's power
uniform float uAnisotropy;        // Henyey-Greenstein g
uniform float uSkyDistance;       // m, how far a sky pixel's ray runs
uniform float uSkyAffect;         // the share of its fog a sky pixel shows (Godot's sky affect)
uniform vec3 uFogColor;           // linear: the fog's colour in shade (lit by the sky alone)
uniform float uAerial;            // effects.aerial_perspective: the sky's share of the fog's colour
uniform vec3 uScatterColor;       // sun colour * intensity * scatter colour * scatter strength

// Depth-aware upsample (Biri 4.3; "nearest-depth" joint bilateral), in steps that the
// held composite shares (passes/composite_inputs.frag keeps each pixel's weights). The
// four fog texels nearest px are k = 0..3 at i0 + (k & 1, k >> 1), i0 the one at or below
// px's centre; f is px's place among them.
ivec2 fogQuad(ivec2 px, out vec2 f) {
    vec2 p = (vec2(px) + 0.5) / float(FOG_SCALE) - 0.5;
    ivec2 i0 = ivec2(floor(p));
    f = p - vec2(i0);
    return i0;
}

// The four texels' bilinear weights at px's place f among them, k = 0..3.
vec4 bilinearWeights(vec2 f) {
    return vec4((1.0 - f.x) * (1.0 - f.y), f.x * (1.0 - f.y), (1.0 - f.x) * f.y, f.x * f.y);
}

vec4 fogTexelOf(ivec2 i0, int k) {
    return texelFetch(uFog, clamp(i0 + ivec2(k & 1, k >> 1), ivec2(0), textureSize(uFog, 0) - 1), 0);
}

// Their weights: bilinear, and by how close each texel's surface (its g, 1/distance) is
// to this pixel's, normalised; with no neighbour on this surface (a thin object), all on
// the closest in depth.
vec4 fogWeights(vec4 s[4], vec2 f, float invd) {
    vec4 w, best = vec4(1.0, 0.0, 0.0, 0.0), wb = bilinearWeights(f);
    float bestRel = 1e9;
    for (int k = 0; k < 4; ++k) {
        // relative depth difference in [0, 1]; 1e-6 1/m keeps sky-vs-sky at 0
        float rel = abs(s[k].g - invd) / max(max(s[k].g, invd), 1e-6);
        w[k] = wb[k] * exp(-rel * rel * 400.0);   // ~5% difference halves the weight
        if (rel < bestRel) { bestRel = rel; best = vec4(k == 0, k == 1, k == 2, k == 3); }
    }
    float wsum = w.x + w.y + w.z + w.w;
    return wsum > 1e-4 ? w / wsum : best;
}

// Gawron eqs. 5-8: p_s = (WorldPos - CameraPos) + ScatterStartDist, the scalar added to
// each component as in the paper's Listing 1; F = max(0, p_s/|p_s| . L)^exponent. With no
// start distance p_s/|p_s| is the view ray w itself. With the Henyey-Greenstein phase,
// F = 4 pi p_HG(p_s/|p_s| . L, g) (common/phase.glsl). The fog's colour is C_fog + C_scatter F.
float scatterLobe(vec3 w, float invd) {
    float dist = invd > 0.0 ? 1.0 / invd : uSkyDistance;
    vec3 ws = uScatterStart > 0.0 ? normalize(w * dist + vec3(uScatterStart)) : w;
    float mu = dot(ws, uSunDir);
    return uPhaseHG ? phaseHG(mu, uAnisotropy) : pow(max(mu, 0.0), uScatterExponent);
}


// The light of a pixel's fog: what the sky lights, (1 - T) uFogColor, and the sunlight it
// scatters toward the eye, the sun's colour times the lobe times J, J the fog texel's
// in-scattered share (passes/fog.frag inScattered, with the particles' light composited
// over it). J belongs to the raw transmittance Traw; the pixel shows the share (1 - T) /
// (1 - Traw) of that fog (max opacity, a sky's share; T >= Traw): J scales with it. 1e-7:
// no fog at all (Traw = 1) has J = 0, and the ratio stays finite.
vec3 fogLight(float T, float Traw, float J, float lobe, vec3 ambient) {
    float share = (1.0 - T) / max(1.0 - Traw, 1e-7);
    return (1.0 - T) * ambient + uScatterColor * lobe * (J * share);
}

// The sky's haze in the fog along the unit view ray w to a surface at 1/distance invd (0:
// the sky): its colour in that direction (common/sky.glsl skyHaze), blurred toward the
// sky's mean for fog near the eye (Godot samples its sky's radiance at a mip by depth
// likewise). The distant land and the sky just above the horizon then meet in the same
// colour. A held composite keeps its far share (fogHazeFar) and the ray's up^0.55 per pixel
// (passes/composite_inputs.frag).
float fogHazeFar(float invd) {
    float d = invd > 0.0 ? 1.0 / invd : uSkyDistance;
    return clamp(d / uSkyDistance, 0.0, 1.0);
}

vec3 fogHaze(vec3 w, float invd) {
    return skyHaze(w, fogHazeFar(invd));
}

// A held composite's 16 bits of the sky per pixel (passes/composite_inputs.frag): whether
// it is the sky, and the haze's far share and its ray's up^0.55 (skyHazeOf) as bytes. The
// low byte is 255 for the sky (whose far share is 1), else the far share in 254ths; the
// high byte is up^0.55 in 255ths. Each byte's rounding moves the haze by at most 1/508 of
// its term (|SKY_ZENITH - SKY_HORIZON| = 0.46 in red: 0.0009), the two together about
// 0.0015 before the exposure: a held frame against the full composite stays within a
// level (tests/gl/test_composite.py; 5.3% of the default look's pixels off by one).
uint heldSkyBits(bool sky, float far, float up055) {
    uint f = sky ? 255u : uint(round(clamp(far, 0.0, 1.0) * 254.0));
    return f | (uint(round(clamp(up055, 0.0, 1.0) * 255.0)) << 8);
}

// (whether the pixel is the sky, the far share, up^0.55) from heldSkyBits
bool heldSky(uint bits) { return (bits & 255u) == 255u; }
vec2 heldHaze(uint bits) {
    return vec2(min(float(bits & 255u) / 254.0, 1.0), float(bits >> 8) / 255.0);
}

// The fog's colour lit by the sky, from the haze along its ray: uFogColor, and with aerial
// perspective (AERIAL) the haze for the share uAerial.
vec3 fogAmbientOf(vec3 haze) {
#if AERIAL
    return mix(uFogColor, haze, uAerial);
#else
    return uFogColor;
#endif
}

// The same along the unit view ray w to a surface at 1/distance invd.
vec3 fogAmbient(vec3 w, float invd) {
#if AERIAL
    return fogAmbientOf(fogHaze(w, invd));
#else
    return uFogColor;
#endif
}
