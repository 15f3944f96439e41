// Instanced quads, one per TILE x TILE pixel tile that passes/silhouette_tiles.frag marked,
// listed by render/targets.py (GBuffer.silhouette_tiles). vUV in [0, 1] across the screen,
// as fullscreen.vert gives it.
// Defined by the renderer: TILE (pixels).
uniform isampler2D uTiles;   // the marked tiles' indices, row-major in the tile grid
uniform int uTileCols;       // tiles a row of the grid
uniform vec2 uViewport;      // the target's size, px
out vec2 vUV;
const vec2 CORNERS[6] = vec2[6](vec2(0, 0), vec2(1, 0), vec2(1, 1), vec2(0, 0), vec2(1, 1), vec2(0, 1));
void main() {
    int width = textureSize(uTiles, 0).x;
    int index = texelFetch(uTiles, ivec2(gl_InstanceID % width, gl_InstanceID / width), 0).r;
    ivec2 tile = ivec2(index % uTileCols, index / uTileCols);
    vec2 px = min((vec2(tile) + CORNERS[gl_VertexID]) * float(TILE), uViewport);
    vUV = px / uViewport;
    gl_Position = vec4(vUV * 2.0 - 1.0, 0.0, 1.0);
}
