// Shades the scene into the G-buffer: linear colour, the inverse of the distance from
// the eye (1/m; 0 is the sky), and the part of the colour that is direct sunlight (linear;
// the composite dims it by the fog toward the sun when effects.sun_through_fog is on). Materials: 0 vertex colour, 1 terrain (procedural grass,
// road, banks, rock), 2 water, 3 unlit (calibration scene: colour out = albedo exactly).
#include "common/sky.glsl"
#include "scene/terrain_albedo.glsl"
in vec3 vPos;
in vec3 vNormal;
in vec3 vColor;
in vec4 vSunPos;
flat in int vMaterial;
uniform vec3 uEye;
uniform vec3 uSunDir;
uniform vec3 uSunColor;
uniform sampler2DShadow uShadow;
uniform float uShadowTexel;
layout(location = 0) out vec4 fColor;
layout(location = 1) out float fInvDist;
layout(location = 2) out vec4 fSunLight;

// Percentage-closer filter over the shadow map; 1 = lit. The sampler filters linearly,
// so each tap is a bilinear 2x2 comparison: four taps half a texel apart cover 3x3
// texels smoothly at less than half the cost of nine point taps.
float sunVisibility(vec3 n) {
    vec3 p = vSunPos.xyz / vSunPos.w * 0.5 + 0.5;
    if (any(lessThan(p, vec3(0.0))) || any(greaterThan(p, vec3(1.0)))) return 1.0;
    // slope-scaled bias against acne: larger where the surface is grazed by the sun
    float bias = 0.0006 + 0.0025 * (1.0 - clamp(dot(n, uSunDir), 0.0, 1.0));
    float s = 0.0;
    for (int i = 0; i < 4; ++i) {
        vec2 o = (vec2(i & 1, i >> 1) - 0.5) * uShadowTexel;
        s += texture(uShadow, vec3(p.xy + o, p.z - bias));
    }
    return s * 0.25;
}

void main() {
    float dist = length(vPos - uEye);
    fInvDist = 1.0 / max(dist, 1e-4);  // 1e-4 m: a fragment at the eye is not "sky"
    if (vMaterial == 3) { fColor = vec4(vColor, 1.0); fSunLight = vec4(0.0); return; }
    vec3 n = normalize(vNormal);
    if (!gl_FrontFacing) n = -n;
    vec3 albedo = vColor;
    vec3 w = (vPos - uEye) / dist;
    if (vMaterial == 1) albedo = terrainAlbedo(vPos, n);
    float sunAmount = max(dot(n, uSunDir), 0.0) * sunVisibility(n);
    vec3 skyAmbient = vec3(0.30, 0.36, 0.46);
    vec3 groundAmbient = vec3(0.16, 0.15, 0.12);
    vec3 ambient = mix(groundAmbient, skyAmbient, n.y * 0.5 + 0.5);
    vec3 sun = albedo * uSunColor * sunAmount * 0.55;
    vec3 c = sun + albedo * ambient;
    if (vMaterial == 2) {
        // water: dark body plus a Fresnel (Schlick, F0 = 0.02) reflection of the sky
        vec3 r = reflect(w, vec3(0.0, 1.0, 0.0));
        float f = 0.02 + 0.98 * pow(1.0 - max(dot(-w, vec3(0.0, 1.0, 0.0)), 0.0), 5.0);
        c = mix(c, skyColor(r, uSunDir, uSunColor) * 0.8, f);
        sun *= 1.0 - f;
    }
    fColor = vec4(c, 1.0);
    fSunLight = vec4(sun, 1.0);
}
