// Two-surface MSAA resolve. Fog depends on each sample's distance, so averaging the
// samples' inverse distances (what a blit does) puts the fog of a depth no sample has on
// the averaged colour of two: along a silhouette the far surface gets the near one's fog
// (a dark or light 1-px outline). Instead each pixel's samples are split into the near
// surface and the far one (by inverse distance, at the midpoint of its range), and each
// group is averaged alone; the composite fogs the two at their own distances and mixes
// them by coverage. This is exact for pixels that see at most two surfaces whose fog is
// uniform within each (an edge; a pixel seeing three is rare and gets the middle one with
// whichever group it is nearer).
// Defined by the renderer: SAMPLES (MSAA samples per pixel), SUN_LIGHT (1: the direct
// sunlight is resolved too).
uniform sampler2DMS uColor;      // scene colour, linear
uniform sampler2DMS uInvDist;    // 1/m; 0 for the sky
uniform sampler2DMS uSunLight;   // the direct sunlight in the colour, linear
layout(location = 0) out vec4 fColor;      // the near surface's colour
layout(location = 1) out float fInvDist;   // its 1/distance
layout(location = 2) out vec4 fFarColor;   // the far surface's colour; a: the near surface's coverage
layout(location = 3) out float fFarInvDist;
layout(location = 4) out vec4 fSunLight;   // the near surface's direct sunlight
layout(location = 5) out vec4 fFarSunLight;

// Two samples are on one surface when their inverse distances differ by less than 5% of
// the larger (the composite's depth-aware weights halve at about that difference);
// 1e-6 1/m keeps sky against sky at 0.
bool oneSurface(float a, float b) {
    return abs(a - b) <= 0.05 * max(max(a, b), 1e-6);
}

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    float inv[SAMPLES];
    float hi = 0.0, lo = 1e30;
    for (int i = 0; i < SAMPLES; ++i) {
        inv[i] = texelFetch(uInvDist, px, i).r;
        hi = max(hi, inv[i]);
        lo = min(lo, inv[i]);
    }
    bool split = !oneSurface(hi, lo);
    float mid = 0.5 * (hi + lo);
    vec4 c[2] = vec4[2](vec4(0.0), vec4(0.0));
    vec4 s[2] = vec4[2](vec4(0.0), vec4(0.0));
    float d[2] = float[2](0.0, 0.0);
    float n[2] = float[2](0.0, 0.0);
    for (int i = 0; i < SAMPLES; ++i) {
        int k = (split && inv[i] < mid) ? 1 : 0;   // 0 near, 1 far
        c[k] += texelFetch(uColor, px, i);
#if SUN_LIGHT
        s[k] += texelFetch(uSunLight, px, i);
#endif
        d[k] += inv[i];
        n[k] += 1.0;
    }
    // n[0] >= 1: the nearest sample is always in the near group
    fColor = c[0] / n[0];
    fInvDist = d[0] / n[0];
    fSunLight = s[0] / n[0];
    float coverage = n[0] / float(SAMPLES);
    if (n[1] > 0.0) {
        fFarColor = vec4((c[1] / n[1]).rgb, coverage);
        fFarInvDist = d[1] / n[1];
        fFarSunLight = s[1] / n[1];
    } else {   // one surface: the far group is the near one, with no weight
        fFarColor = vec4(fColor.rgb, 1.0);
        fFarInvDist = fInvDist;
        fFarSunLight = fSunLight;
    }
}
