// A preview's scene pass warped from the warp base, an earlier preview's drawn from the same
// eye (passes/warp_seen.glsl): each pixel takes what the base saw along its own ray, from
// the nearest texel. Its depth is the mask of the draws that follow (passes/scene.py,
// passes/sky.frag): 0 where the base saw the ray, so that nothing is drawn there; 1 (the
// far plane, as a cleared target) where it did not, and the scene and the sky are drawn
// anew.
// Defined by the renderer: SUN_LIGHT (the G-buffer has the direct sunlight).
#include "passes/warp_seen.glsl"
in vec2 vUV;
uniform sampler2D uBaseColor;                 // linear
uniform sampler2D uBaseInvDist;               // 1/m, 0 the sky
uniform sampler2D uBaseSunLight;              // linear
layout(location = 0) out vec4 fColor;
layout(location = 1) out float fInvDist;
layout(location = 2) out vec4 fSunLight;

void main() {
    bool seen;
    vec2 ndc = baseNdc(vUV, seen);
    gl_FragDepth = seen ? 0.0 : 1.0;
    ivec2 t = baseTexel(ndc, textureSize(uBaseColor, 0));
    fColor = vec4(texelFetch(uBaseColor, t, 0).rgb, 1.0);
    fInvDist = texelFetch(uBaseInvDist, t, 0).r;
#if SUN_LIGHT
    fSunLight = texelFetch(uBaseSunLight, t, 0);
#else
    fSunLight = vec4(0.0);
#endif
}
