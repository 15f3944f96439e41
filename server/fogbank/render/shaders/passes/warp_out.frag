// A preview's finished frame warped from the slot's last preview drawn whole (at any size),
// from the same eye, of the same look but for the camera's turn and the time
// (render/reproject.py):
// each pixel takes the base frame's nearest texel along its own ray
// (passes/warp_seen.glsl), 8-bit sRGB as it was output. Its depth is the mask of the
// composite that follows (passes/composite.py): 0 where the base saw the ray, 1 where it
// did not, and only there is the frame composited anew.
#include "passes/warp_seen.glsl"
in vec2 vUV;
uniform sampler2D uBaseOut;                   // the base frame, RGBA8 as output
layout(location = 0) out vec4 fColor;

void main() {
    bool seen;
    vec2 ndc = baseNdc(vUV, seen);
    gl_FragDepth = seen ? 0.0 : 1.0;
    fColor = texelFetch(uBaseOut, baseTexel(ndc, textureSize(uBaseOut, 0)), 0);
}
