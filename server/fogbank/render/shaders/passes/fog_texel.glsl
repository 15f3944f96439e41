// The visible point behind one fog-target texel: the nearest surface (max inverse
// distance) of its uFogScale x uFogScale block of the full-resolution G-buffer, and the
// view ray through the block's centre. Shared by the fog pass and the particle quads.
// The scale is a uniform, not a define: one compiled fog program serves every fog scale,
// so the previews' coarser fog costs no compile of its own (a fog program of many kinds
// takes llvmpipe up to seconds to compile).
struct FogTexel { vec3 w; float invd; };
uniform int uFogScale;   // 1, 2 or 4: full-resolution pixels per fog texel side

// The view ray through the centre of the fog texel at fragCoord, in a frame `full` pixels
// in size.
vec3 fogTexelRay(vec2 fragCoord, ivec2 full, vec3 fwd, vec3 right, vec3 up) {
    ivec2 base = ivec2(fragCoord) * uFogScale;
    vec2 ndc = (vec2(base) + 0.5 * float(uFogScale)) / vec2(full) * 2.0 - 1.0;
    return viewRay(ndc, fwd, right, up);
}

FogTexel fogTexel(vec2 fragCoord, sampler2D invDist, vec3 fwd, vec3 right, vec3 up) {
    ivec2 full = textureSize(invDist, 0);
    ivec2 base = ivec2(fragCoord) * uFogScale;
    float invd = 0.0;
    for (int y = 0; y < uFogScale; ++y)
        for (int x = 0; x < uFogScale; ++x)
            invd = max(invd, texelFetch(invDist, min(base + ivec2(x, y), full - 1), 0).r);
    return FogTexel(fogTexelRay(fragCoord, full, fwd, right, up), invd);
}
