// Which TILE x TILE pixel tiles of a held composite (render/passes/composite.py) need the
// kept depth-aware weights (passes/composite_inputs.frag W): those with a pixel whose
// weights differ from the bilinear ones by more than EDGE_WEIGHT in any of the four. The
// others blend the fog bilinearly (passes/composite_held.glsl heldFogTSmooth), which errs
// by sum_k (w_k - wb_k) (T_k - c) <= 2 EDGE_WEIGHT x the spread of the four texels' T.
// Drawn at one fragment per tile, once per held fog (the weights read nothing else).
// Defined by the renderer: FOG_SCALE (2, 4), TILE (pixels), EDGE_WEIGHT.
#include "passes/composite_parts.glsl"
uniform sampler2D uHeldW;         // the four fog texels' upsample weights, per pixel
layout(location = 0) out float fEdge;
void main() {
    ivec2 size = textureSize(uHeldW, 0);
    ivec2 base = ivec2(gl_FragCoord.xy) * TILE;
    float dev = 0.0;
    for (int y = 0; y < TILE; ++y)
        for (int x = 0; x < TILE; ++x) {
            ivec2 p = min(base + ivec2(x, y), size - 1);
            vec2 f;
            fogQuad(p, f);
            vec4 d = abs(texelFetch(uHeldW, p, 0) - bilinearWeights(f));
            dev = max(dev, max(max(d.x, d.y), max(d.z, d.w)));
        }
    fEdge = dev > EDGE_WEIGHT ? 1.0 : 0.0;
}
