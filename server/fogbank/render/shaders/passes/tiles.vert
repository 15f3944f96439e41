// Instanced quads, one per run of TILE x TILE pixel tiles along a row of the tile grid
// that passes/silhouette_tiles.frag marked, listed by render/targets.py
// (GBuffer.silhouette_tiles). vUV in [0, 1] across the screen, as fullscreen.vert gives it.
// Defined by the renderer: TILE (pixels).
uniform isampler2D uTiles;   // the runs: (first tile's index, row-major in the tile grid; tiles in the run)
uniform int uTileCols;       // tiles a row of the grid
uniform vec2 uViewport;      // the target's size, px
out vec2 vUV;
const vec2 CORNERS[6] = vec2[6](vec2(0, 0), vec2(1, 0), vec2(1, 1), vec2(0, 0), vec2(1, 1), vec2(0, 1));
void main() {
    int width = textureSize(uTiles, 0).x;
    ivec2 run = texelFetch(uTiles, ivec2(gl_InstanceID % width, gl_InstanceID / width), 0).rg;
    ivec2 tile = ivec2(run.x % uTileCols, run.x / uTileCols);
    vec2 corner = CORNERS[gl_VertexID] * vec2(float(run.y), 1.0);
    vec2 px = min((vec2(tile) + corner) * float(TILE), uViewport);
    vUV = px / uViewport;
    gl_Position = vec4(vUV * 2.0 - 1.0, 0.0, 1.0);
}
