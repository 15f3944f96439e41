// The composite of a stream frame whose camera stays still (render/passes/composite.py):
// every pixel's near surface from what passes/composite_inputs.frag kept of the still
// scene and held fog (passes/composite_held.glsl heldNear). The pixels with a far surface
// are redone by passes/composite.frag's second draw (HELD_NEAR). With a coarser fog, two
// draws share the pixels by a depth test against passes/held_edges.frag's marks: SMOOTH 1
// where the kept weights are the bilinear ones (heldFogTSmooth), SMOOTH 0 elsewhere.
// Defined by the renderer: FOG_SCALE (1, 2, 4), BLUR_MODE (0 off, 2 separate passes
// follow; the fused blur takes passes/composite.frag), SUN_LIGHT, SMOOTH.
// packHalf2x16 / unpackHalf2x16 (core from GLSL 4.20): the held inputs' AB
#extension GL_ARB_shading_language_packing : require
#include "common/srgb.glsl"
#include "fog/finish.glsl"
#include "passes/composite_parts.glsl"
#include "passes/composite_held.glsl"
in vec2 vUV;
layout(location = 0) out vec4 fColor;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
#if SMOOTH
    vec4 c = heldNearOf(px, heldFogTSmooth(px));
#else
    vec4 c = heldNear(px);
#endif
    if (BLUR_MODE == 2) fColor = vec4(c.rgb, 1.0 - c.a);     // linear, fog amount for the blur
    else fColor = vec4(outputColor(c.rgb, vec2(px)), 1.0);
}
