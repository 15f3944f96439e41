// A pixel's near surface under the fog from the held composite's inputs
// (passes/composite_inputs.frag): passes/composite.frag's fogged() for a still scene and
// a held fog, in which only the fog texels' raw T, T toward the sun and in-scattered
// sunlight move, blended by the kept upsample weights. Used by passes/composite_held.frag for every pixel, and by
// the two-surface draw (passes/composite.frag HELD_NEAR) for the near surface.
// Defined by the renderer: FOG_SCALE (1, 2, 4), SUN_LIGHT, AERIAL.
uniform usampler2D uHeldAB;       // as seven halves and 16 bits:
                                  //   A (scene less direct sunlight, linear; in-scattering lobe)
                                  //   B (direct sunlight, linear), the sky's bits (heldSkyBits)
uniform sampler2D uHeldW;         // the four fog texels' upsample weights

// The fog texels' (raw T, T toward the sun, in-scattered sunlight) at px by the kept weights.
vec3 heldFogT(ivec2 px) {
#if FOG_SCALE == 1
    return texelFetch(uFog, px, 0).rba;
#else
    vec4 w = texelFetch(uHeldW, px, 0);
    vec2 f;
    ivec2 i0 = fogQuad(px, f);
    return w.x * fogTexelOf(i0, 0).rba + w.y * fogTexelOf(i0, 1).rba
         + w.z * fogTexelOf(i0, 2).rba + w.w * fogTexelOf(i0, 3).rba;
#endif
}

// The same where the kept weights are the bilinear ones (passes/held_edges.frag marks the
// tiles where they are not): one filtered fetch instead of the weights and four texels.
// uFog is filtered LINEAR and clamped to its edge (render/targets.py), so the texture unit
// interpolates between the same four texels fogQuad names (a GPU's filter weights have 8
// fractional bits: at most 1/512 of the four texels' spread off).
vec3 heldFogTSmooth(ivec2 px) {
    return texture(uFog, (vec2(px) + 0.5) / (float(FOG_SCALE) * vec2(textureSize(uFog, 0)))).rba;
}

// (linear colour, T) of the pixel's near surface from its fog texels' (raw T, T toward the
// sun, in-scattered sunlight)
vec4 heldNearOf(ivec2 px, vec3 Ts) {
    uvec4 ab = texelFetch(uHeldAB, px, 0);
    vec4 a = vec4(unpackHalf2x16(ab.x), unpackHalf2x16(ab.y));
    vec3 sun = vec3(unpackHalf2x16(ab.z), unpackHalf2x16(ab.w).x);
    uint skyBits = ab.w >> 16;
    float share = heldSky(skyBits) ? uSkyAffect : 1.0;
    float T = 1.0 - share * (1.0 - fogFinish(Ts.x));   // the sky shows only its share of the fog
    vec3 scene = a.rgb;
#if SUN_LIGHT
    scene += Ts.y * sun;   // the scene less the share 1 - T_sun of its direct sunlight
#endif
#if AERIAL
    // the fog's colour depends on the view ray and the distance, both still: kept per pixel
    vec2 haze = heldHaze(skyBits);
    vec3 ambient = fogAmbientOf(skyHazeOf(haze.x, haze.y));
#else
    vec3 ambient = uFogColor;
#endif
    return vec4(T * scene + fogLight(T, Ts.x, Ts.z, a.a, ambient), T);
}

// (linear colour, T) of the pixel's near surface
vec4 heldNear(ivec2 px) {
    return heldNearOf(px, heldFogT(px));
}
