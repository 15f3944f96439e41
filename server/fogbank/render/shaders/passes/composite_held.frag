// The composite of a stream frame whose camera stays still (render/passes/composite.py):
// passes/composite.frag's near surface, C = T C_scene + (1 - T) C_fog (Biri eq. 5) with
// the direct sunlight dimmed by the fog toward the sun and Gawron's in-scattering, from
// what passes/composite_inputs.frag kept of the still scene and held fog. Only the fog
// texels' raw T and T toward the sun move, blended by the kept upsample weights.
// Defined by the renderer: FOG_SCALE (1, 2, 4), BLUR_MODE (0 off, 2 separate passes
// follow; the fused blur takes passes/composite.frag), SUN_LIGHT.
#include "common/srgb.glsl"
#include "fog/finish.glsl"
#include "passes/composite_parts.glsl"
in vec2 vUV;
uniform sampler2D uHeldA;         // (scene less direct sunlight, linear; in-scattering lobe x lit term)
uniform sampler2D uHeldB;         // (direct sunlight, linear; the pixel's share of its fog)
uniform sampler2D uHeldW;         // the four fog texels' upsample weights
uniform vec3 uFogColor;           // linear
uniform vec3 uScatterColor;       // sun colour * intensity * scatter colour * scatter strength
layout(location = 0) out vec4 fColor;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 a = texelFetch(uHeldA, px, 0);
    vec4 b = texelFetch(uHeldB, px, 0);
#if FOG_SCALE == 1
    vec2 Ts = texelFetch(uFog, px, 0).rb;
#else
    vec4 w = texelFetch(uHeldW, px, 0);
    vec2 f;
    ivec2 i0 = fogQuad(px, f);
    vec2 Ts = w.x * fogTexelOf(i0, 0).rb + w.y * fogTexelOf(i0, 1).rb
            + w.z * fogTexelOf(i0, 2).rb + w.w * fogTexelOf(i0, 3).rb;
#endif
    float T = 1.0 - b.a * (1.0 - fogFinish(Ts.x));   // the sky shows only its share of the fog
    vec3 scene = a.rgb;
#if SUN_LIGHT
    scene += Ts.y * b.rgb;   // the scene less the share 1 - T_sun of its direct sunlight
#endif
    vec3 c = T * scene + (1.0 - T) * (uFogColor + uScatterColor * a.a);
    if (BLUR_MODE == 2) fColor = vec4(c, 1.0 - T);     // linear, fog amount for the blur
    else fColor = vec4(outputColor(c, vec2(px)), 1.0);
}
