// Which TILE x TILE pixel tiles hold a pixel that sees two surfaces (passes/resolve.frag
// writes the near surface's coverage, below 1 there, into the far colour's alpha): the
// composite's second draw covers only these tiles (passes/tiles.vert).
// Defined by the renderer: TILE (pixels).
uniform sampler2D uFarColor;
layout(location = 0) out float fAny;
void main() {
    ivec2 size = textureSize(uFarColor, 0);
    ivec2 base = ivec2(gl_FragCoord.xy) * TILE;
    float any = 0.0;
    for (int y = 0; y < TILE; ++y)
        for (int x = 0; x < TILE; ++x) {
            ivec2 p = base + ivec2(x, y);
            if (all(lessThan(p, size)) && texelFetch(uFarColor, p, 0).a < 1.0) any = 1.0;
        }
    fAny = any;
}
