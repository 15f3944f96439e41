// A preview's scene pass warped from the warp base, an earlier preview's drawn from the same
// eye (render/reproject.py): a turn about the eye maps the image onto itself, the
// homography K R K^-1, whatever the depth. Each pixel takes what the base saw along its
// own ray, from the nearest texel (within half a texel of its place: no blur, and no
// distance mixed across a silhouette, which would belong to neither surface). Its depth
// is the mask of the draws that follow (passes/scene.py, passes/sky.frag): 0 where the
// base saw the ray (inside its image), so that nothing is drawn there;
// 1 (the far plane, as a cleared target) where it did not, and the scene and the sky are
// drawn anew.
// Defined by the renderer: SUN_LIGHT (the G-buffer has the direct sunlight).
#include "common/camera.glsl"
in vec2 vUV;
uniform vec3 uFwd, uRight, uUp;               // this frame's basis, right and up scaled by tan(fov/2) (right by the aspect too)
uniform vec3 uBaseFwd, uBaseRight, uBaseUp;   // the base's, alike
uniform sampler2D uBaseColor;                 // linear
uniform sampler2D uBaseInvDist;               // 1/m, 0 the sky
uniform sampler2D uBaseSunLight;              // linear
layout(location = 0) out vec4 fColor;
layout(location = 1) out float fInvDist;
layout(location = 2) out vec4 fSunLight;

void main() {
    vec3 w = viewRay(vUV * 2.0 - 1.0, uFwd, uRight, uUp);
    // the base's normalised device coordinates of w (w = fwd + x right + y up, scaled):
    // x = (w . right) / |right|^2 / (w . fwd). 1e-6: a ray at right angles to the base's
    // axis or behind it, which the base did not see
    float z = dot(w, uBaseFwd);
    vec2 ndc = vec2(dot(w, uBaseRight) / dot(uBaseRight, uBaseRight),
                    dot(w, uBaseUp) / dot(uBaseUp, uBaseUp)) / max(z, 1e-6);
    ivec2 size = textureSize(uBaseColor, 0);
    gl_FragDepth = (z > 1e-6 && all(lessThanEqual(abs(ndc), vec2(1.0)))) ? 0.0 : 1.0;
    // the nearest texel (clamped: a ray outside is drawn anew)
    ivec2 t = clamp(ivec2(floor((ndc * 0.5 + 0.5) * vec2(size))), ivec2(0), size - 1);
    fColor = vec4(texelFetch(uBaseColor, t, 0).rgb, 1.0);
    fInvDist = texelFetch(uBaseInvDist, t, 0).r;
#if SUN_LIGHT
    fSunLight = texelFetch(uBaseSunLight, t, 0);
#else
    fSunLight = vec4(0.0);
#endif
}
