// The held composite's two-surface pixels, drawn packed (passes/composite.frag COMPACT),
// each copied to its place: drawn over the silhouette tiles (passes/tiles.vert), every
// pixel of one surface leaves at once. The copy is exact: the packed target has the
// output's format (render/targets.py HeldFog.far_target).
// Defined by the renderer: FAR_LIST_WIDTH (texels a row of the packed target), TILE.
uniform isampler2D uFarIndex;     // each pixel's place in the list, -1: one surface
uniform sampler2D uFarOut;        // the listed pixels' composite
layout(location = 0) out vec4 fColor;

void main() {
    int i = texelFetch(uFarIndex, ivec2(gl_FragCoord.xy), 0).r;
    if (i < 0) discard;
    fColor = texelFetch(uFarOut, ivec2(i % FAR_LIST_WIDTH, i / FAR_LIST_WIDTH), 0);
}
