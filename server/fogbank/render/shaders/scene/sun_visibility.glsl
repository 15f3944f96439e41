// How much of the sun a surface point sees through the scene's shadow map, 1 = lit.
// sunPos: the point in the sun's clip space (uSunViewProj); n: its unit normal.
uniform vec3 uSunDir;
uniform sampler2DShadow uShadow;
uniform float uShadowTexel;   // 1 / the shadow map's side, texels
uniform float uShadowBiasScale;   // times the full map's bias: 1, or a preview map's (render/resources.py DRAFT_SHADOW_BIAS)

// Percentage-closer filter over the shadow map. The sampler filters linearly, so each
// tap is a bilinear 2x2 comparison: four taps half a texel apart cover 3x3 texels
// smoothly at less than half the cost of nine point taps. Outside the map: lit.
float sunVisibility(vec4 sunPos, vec3 n) {
    vec3 p = sunPos.xyz / sunPos.w * 0.5 + 0.5;
    if (any(lessThan(p, vec3(0.0))) || any(greaterThan(p, vec3(1.0)))) return 1.0;
    // slope-scaled bias against acne: larger where the surface is grazed by the sun, and
    // for a preview's map (a wider texel spans more depth of a sloped surface, and its
    // coarser terrain lies up to its level's error off the surface)
    float bias = (0.0006 + 0.0025 * (1.0 - clamp(dot(n, uSunDir), 0.0, 1.0))) * uShadowBiasScale;
    float s = 0.0;
    for (int i = 0; i < 4; ++i) {
        vec2 o = (vec2(i & 1, i >> 1) - 0.5) * uShadowTexel;
        s += texture(uShadow, vec3(p.xy + o, p.z - bias));
    }
    return s * 0.25;
}
