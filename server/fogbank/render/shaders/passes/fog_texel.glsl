// The visible point behind one fog-target texel: the nearest surface (max inverse
// distance) of its FOG_SCALE x FOG_SCALE block of the full-resolution G-buffer, and the
// view ray through the block's centre. Shared by the fog pass and the particle quads.
struct FogTexel { vec3 w; float invd; };

FogTexel fogTexel(vec2 fragCoord, sampler2D invDist, vec3 fwd, vec3 right, vec3 up) {
    ivec2 full = textureSize(invDist, 0);
    ivec2 base = ivec2(fragCoord) * FOG_SCALE;
    float invd = 0.0;
    for (int y = 0; y < FOG_SCALE; ++y)
        for (int x = 0; x < FOG_SCALE; ++x)
            invd = max(invd, texelFetch(invDist, min(base + ivec2(x, y), full - 1), 0).r);
    vec2 ndc = (vec2(base) + 0.5 * float(FOG_SCALE)) / vec2(full) * 2.0 - 1.0;
    return FogTexel(viewRay(ndc, fwd, right, up), invd);
}
