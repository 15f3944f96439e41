// The held composite's inputs (render/passes/composite.py): for a stream whose camera
// stays still, what passes/composite.frag computes per pixel from the scene pass and the
// held fog (passes/fog.py), neither of which changes while time runs, drawn once:
//   AB: seven halves (packHalf2x16) and 16 bits in one RGBA32UI texel, so that each frame
//       fetches them once (llvmpipe pays about 1 ms a fetch over a 1280x720 frame, little
//       more for 16 bytes than for 8):
//     A: (the scene colour less its direct sunlight with SUN_LIGHT, else the scene colour;
//         the in-scattering lobe F)
//     B: (the direct sunlight, linear) as three halves, and in the last 16 bits whether
//        the pixel is the sky (which shows the share uSkyAffect of its fog, a surface all
//        of it) and, with AERIAL, the sky's haze along its ray to its surface as two bytes
//        (heldSkyBits: a fetch of its own cost llvmpipe 2.5 ms over a 1280x720 frame)
//   W: the depth-aware upsample's weights of the four fog texels (fogWeights)
// so that each frame (passes/composite_held.frag) only blends the moving fog texels.
// Defined by the renderer: FOG_SCALE (1, 2, 4), SUN_LIGHT, AERIAL.
// packHalf2x16 / unpackHalf2x16 (core from GLSL 4.20): the held inputs' AB
#extension GL_ARB_shading_language_packing : require
#include "common/camera.glsl"
#include "passes/composite_parts.glsl"
in vec2 vUV;
uniform sampler2D uColor;         // scene colour, linear
uniform sampler2D uSunLight;      // the direct sunlight in the scene colour, linear
layout(location = 0) out uvec4 fAB;
layout(location = 1) out vec4 fW;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    float invd = texelFetch(uInvDist, px, 0).r;
    vec3 w = viewRay(vUV * 2.0 - 1.0, uFwd, uRight, uUp);
#if FOG_SCALE == 1
    fW = vec4(1.0, 0.0, 0.0, 0.0);
#else
    vec2 f;
    ivec2 i0 = fogQuad(px, f);
    vec4 s[4] = vec4[4](fogTexelOf(i0, 0), fogTexelOf(i0, 1), fogTexelOf(i0, 2), fogTexelOf(i0, 3));
    fW = fogWeights(s, f, invd);
#endif
    vec3 scene = texelFetch(uColor, px, 0).rgb;
    vec3 sun = vec3(0.0);
#if SUN_LIGHT
    sun = texelFetch(uSunLight, px, 0).rgb;
#endif
    vec4 a = vec4(scene - sun, scatterLobe(w, invd));
#if AERIAL
    uint skyBits = heldSkyBits(invd <= 0.0, fogHazeFar(invd), skyHazeUp(w));
#else
    uint skyBits = heldSkyBits(invd <= 0.0, 0.0, 0.0);
#endif
    fAB = uvec4(packHalf2x16(a.rg), packHalf2x16(a.ba), packHalf2x16(sun.rg),
                (packHalf2x16(vec2(sun.b, 0.0)) & 0xFFFFu) | (skyBits << 16));
}
