// passes/held_edges.frag's tiles as depths, for the held composite's two draws
// (render/passes/composite.py): a fullscreen triangle lies at depth 0.5, so the smooth
// tiles (0.75) pass a "<" test and the marked ones (0.25) a ">" test.
// Defined by the renderer: TILE (pixels).
uniform sampler2D uEdges;         // one texel per tile: 1 marked, 0 smooth
void main() {
    gl_FragDepth = texelFetch(uEdges, ivec2(gl_FragCoord.xy) / TILE, 0).r > 0.5 ? 0.25 : 0.75;
}
