// The held composite's two-surface pixels, drawn packed (passes/composite.frag COMPACT),
// each copied to its place: drawn over the silhouette tiles (passes/tiles.vert), every
// pixel of one surface leaves at once. The list runs tile by tile, a tile's pixels row by
// row (render/targets.py HeldFog.far_pixels), so a pixel's place is its tile's first place
// plus the tile's listed pixels before it. The copy is exact: the packed target has the
// output's format (render/targets.py HeldFog.far_target).
// Defined by the renderer: FAR_LIST_WIDTH (texels a row of the packed target), TILE (4: a
// tile's 16 pixels are the bits of its mask).
uniform isampler2D uFarTiles;     // per tile: (its first pixel's place in the list, mask of its listed pixels)
uniform sampler2D uFarOut;        // the listed pixels' composite
layout(location = 0) out vec4 fColor;

// The set bits of v < 2^16 (GLSL 3.30 has no bitCount): pairs, nibbles, bytes summed.
uint bitCount16(uint v) {
    v = v - ((v >> 1) & 0x5555u);
    v = (v & 0x3333u) + ((v >> 2) & 0x3333u);
    v = (v + (v >> 4)) & 0x0F0Fu;
    return (v + (v >> 8)) & 0x1Fu;
}

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    ivec2 tile = texelFetch(uFarTiles, px / TILE, 0).rg;
    int k = (px.y % TILE) * TILE + px.x % TILE;   // the pixel in its tile, row by row
    uint mask = uint(tile.y);
    if (((mask >> uint(k)) & 1u) == 0u) discard;
    int i = tile.x + int(bitCount16(mask & ((1u << uint(k)) - 1u)));
    fColor = texelFetch(uFarOut, ivec2(i % FAR_LIST_WIDTH, i / FAR_LIST_WIDTH), 0);
}
