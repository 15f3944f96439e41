// The mask of a preview whose finished frame is warped (passes/warp_out.frag): depth 0 where
// the base saw the pixel's ray, 1 where it did not (passes/warp_seen.glsl). The scene pass
// then draws the scene and the sky only where the base did not see (colour writes are
// off while this draws).
#include "passes/warp_seen.glsl"
in vec2 vUV;

void main() {
    bool seen;
    baseNdc(vUV, seen);
    gl_FragDepth = seen ? 0.0 : 1.0;
}
