// Exposure and tone mapping: the frame's linear HDR light (linear sRGB primaries,
// scene-referred: the sun's disc, its glow and forward-scattering fog exceed 1) to display
// light in [0, 1], before the sRGB encoding (common/srgb.glsl). TONE_MAP, defined by the
// renderer (render/passes/output.py TONE_MAPS): 0 none (the encoding clips at 1, the
// papers' output), 1 Khronos PBR Neutral, 2 AgX. Both curves are branch-free selects:
// llvmpipe runs both sides of a data-dependent branch anyway.
#ifndef TONE_MAP
#define TONE_MAP 0
#endif
uniform float uExposureScale;     // 2^EV (effects.exposure), unitless

// Khronos PBR Neutral (Khronos 3D Formats Working Group, "PBR Neutral tone mapping
// specification", 2024): a base colour under white light of up to 0.8 comes out as it
// went in, but for a toe that lifts no channel (a quadratic x - 6.25 x^2 below 0.08, then
// a constant 0.04 subtracted); above 0.76 the peak channel is rolled off toward 1,
// 1 - d^2 / (peak + d - 0.76) with d = 0.24, all channels scaled alike (no hue shift),
// then mixed toward white by 1 - 1 / (0.15 (peak - newPeak) + 1). Inputs >= 0.
vec3 toneMapNeutral(vec3 c) {
    const float start = 0.8 - 0.04;
    const float d = 1.0 - start;
    float x = min(c.r, min(c.g, c.b));
    c -= x < 0.08 ? x - 6.25 * x * x : 0.04;
    float peak = max(c.r, max(c.g, c.b));
    float newPeak = 1.0 - d * d / (peak + d - start);
    // 1e-6: the select below discards this side when peak < start (peak may be 0 there)
    vec3 rolled = c * (newPeak / max(peak, 1e-6));
    float g = 1.0 - 1.0 / (0.15 * (peak - newPeak) + 1.0);
    rolled = mix(rolled, vec3(newPeak), g);
    return peak < start ? c : rolled;
}

// AgX (Troy Sobotka, 2022; the base curve as Blender 4 and Filament ship it, with
// Benjamin Wrensch's polynomial fit of its sigmoid): into BT.2020 primaries, an inset
// toward the achromatic axis (which bends highlights toward white), a log2 encoding of
// [-12.47393, +4.026069] EV around middle grey (2^-10 to 2^6.5 times 0.18), the sigmoid,
// the outset, back to linear (power 2.2) and to BT.709 primaries. Grey stays grey: each
// matrix's rows sum to 1. mat3 takes columns.
const mat3 AGX_709_TO_2020 = mat3(vec3(0.6274, 0.0691, 0.0164), vec3(0.3293, 0.9195, 0.0880),
                                  vec3(0.0433, 0.0113, 0.8956));
const mat3 AGX_2020_TO_709 = mat3(vec3(1.6605, -0.1246, -0.0182), vec3(-0.5876, 1.1329, -0.1006),
                                  vec3(-0.0728, -0.0083, 1.1187));
const mat3 AGX_INSET = mat3(vec3(0.856627153315983, 0.137318972929847, 0.11189821299995),
                            vec3(0.0951212405381588, 0.761241990602591, 0.0767994186031903),
                            vec3(0.0482516061458583, 0.101439036467562, 0.811302368396859));
const mat3 AGX_OUTSET = mat3(vec3(1.1271005818144368, -0.1413297634984383, -0.14132976349843826),
                             vec3(-0.11060664309660323, 1.157823702216272, -0.11060664309660294),
                             vec3(-0.016493938717834573, -0.016493938717834257, 1.2519364065950405));

vec3 toneMapAgX(vec3 c) {
    const float minEv = -12.47393, maxEv = 4.026069;
    c = AGX_INSET * (AGX_709_TO_2020 * c);
    // 1e-10: log2 of 0 (black) is -inf; anything below 2^-12.5 clamps to the curve's foot
    c = clamp((log2(max(c, 1e-10)) - minEv) / (maxEv - minEv), 0.0, 1.0);
    vec3 x2 = c * c, x4 = x2 * x2;
    c = 15.5 * x4 * x2 - 40.14 * x4 * c + 31.96 * x4 - 6.868 * x2 * c + 0.4298 * x2 + 0.1191 * c - 0.00232;
    c = pow(max(AGX_OUTSET * c, 0.0), vec3(2.2));
    return clamp(AGX_2020_TO_709 * c, 0.0, 1.0);
}

// Linear scene light to display light in [0, 1] (TONE_MAP 0: exposed only, and the
// encoding clips it).
vec3 toneMap(vec3 c) {
    c = max(c, 0.0) * uExposureScale;
#if TONE_MAP == 1
    c = toneMapNeutral(c);
#elif TONE_MAP == 2
    c = toneMapAgX(c);
#endif
    return c;
}
