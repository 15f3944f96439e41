// Instanced quads, one per TILE x TILE pixel tile that uTiles marks (passes/silhouette_tiles.frag);
// an unmarked tile's quad collapses to a point and draws nothing. vUV in [0, 1] across the
// screen, as fullscreen.vert gives it.
// Defined by the renderer: TILE (pixels).
uniform sampler2D uTiles;
uniform vec2 uViewport;   // the target's size, px
out vec2 vUV;
const vec2 CORNERS[6] = vec2[6](vec2(0, 0), vec2(1, 0), vec2(1, 1), vec2(0, 0), vec2(1, 1), vec2(0, 1));
void main() {
    int cols = textureSize(uTiles, 0).x;
    ivec2 tile = ivec2(gl_InstanceID % cols, gl_InstanceID / cols);
    if (texelFetch(uTiles, tile, 0).r < 0.5) {
        vUV = vec2(0.0);
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);   // outside the clip volume: culled
        return;
    }
    vec2 px = min((vec2(tile) + CORNERS[gl_VertexID]) * float(TILE), uViewport);
    vUV = px / uViewport;
    gl_Position = vec4(vUV * 2.0 - 1.0, 0.0, 1.0);
}
