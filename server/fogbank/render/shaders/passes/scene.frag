// Shades the scene into the G-buffer: linear colour, the inverse of the distance from
// the eye (1/m; 0 is the sky), and the part of the colour that is direct sunlight (linear;
// the composite dims it by the fog toward the sun when effects.sun_through_fog is on).
// TERRAIN 1: the ground (procedural grass, road, banks, rock; sun visibility from the
// baked lightmap). TERRAIN 0: everything else, by material: 0 vertex colour, 2 water,
// 3 unlit (calibration scene: colour out = albedo exactly). Every lit surface is seen
// through the air's haze (common/sky.glsl atmosphereHaze). Two programs, not a branch:
// llvmpipe runs both sides of a branch under a lane mask, so every fragment paid for the
// terrain's albedo and the water's reflection.
#include "common/sky.glsl"
#include "scene/sun_visibility.glsl"
#if TERRAIN
#include "scene/terrain_albedo.glsl"
uniform sampler2D uLightmap;   // the terrain's sun visibility (passes/lightmap.frag)
uniform vec4 uLightmapRect;    // x0, z0 (m), 1 / the side (1/m)
#endif
in vec3 vPos;
in vec3 vNormal;
in vec3 vColor;
in vec4 vSunPos;
flat in int vMaterial;
uniform vec3 uEye;
uniform vec3 uSunColor;
layout(location = 0) out vec4 fColor;
layout(location = 1) out float fInvDist;
layout(location = 2) out vec4 fSunLight;

uniform float uFar;   // m: the far plane (scene/camera.py FAR)

void main() {
    // min(uFar): a partly covered pixel is shaded at its centre, which may lie off the
    // triangle; a triangle that runs to the horizon extrapolates there to a point beyond
    // anything drawn (1.6e6 m in a horizon row), whose fog float32 then integrates badly.
    // Nothing drawn lies beyond the far plane.
    float dist = min(length(vPos - uEye), uFar);
    fInvDist = 1.0 / max(dist, 1e-4);  // 1e-4 m: a fragment at the eye is not "sky"
#if !TERRAIN
    if (vMaterial == 3) { fColor = vec4(vColor, 1.0); fSunLight = vec4(0.0); return; }
#endif
    vec3 n = normalize(vNormal);
    // a back face shows its normal's side; a terrain chunk's skirt (material 4, hanging
    // straight down from the chunk's border, scene/meshes.py) is seen from either side
    // and is shaded as the border it hangs from
    if (!gl_FrontFacing && vMaterial != 4) n = -n;
    vec3 w = (vPos - uEye) / dist;
#if TERRAIN
    vec3 albedo = terrainAlbedo(vPos, n);
    // outside the lightmap's square the shadow map has no say either: lit
    vec2 uv = (vPos.xz - uLightmapRect.xy) * uLightmapRect.zw;
    float inside = float(all(greaterThanEqual(uv, vec2(0.0))) && all(lessThanEqual(uv, vec2(1.0))));
    float visible = mix(1.0, texture(uLightmap, uv).r, inside);
#else
    vec3 albedo = vColor;
    float visible = sunVisibility(vSunPos, n);
#endif
    float sunAmount = max(dot(n, uSunDir), 0.0) * visible;
    vec3 skyAmbient = vec3(0.30, 0.36, 0.46);
    vec3 groundAmbient = vec3(0.16, 0.15, 0.12);
    vec3 ambient = mix(groundAmbient, skyAmbient, n.y * 0.5 + 0.5);
    vec3 sun = albedo * uSunColor * sunAmount * 0.55;
    vec3 c = sun + albedo * ambient;
#if !TERRAIN
    if (vMaterial == 2) {
        // water: dark body plus a Fresnel (Schlick, F0 = 0.02) reflection of the sky
        vec3 r = reflect(w, vec3(0.0, 1.0, 0.0));
        float f = 0.02 + 0.98 * pow(1.0 - max(dot(-w, vec3(0.0, 1.0, 0.0)), 0.0), 5.0);
        c = mix(c, skyColor(r, uSunDir, uSunColor) * 0.8, f);
        sun *= 1.0 - f;
    }
#endif
    // the air between (common/sky.glsl): its share of the light is the sky's haze
    float air = exp(-dist / ATMOSPHERE_M);
    c = mix(atmosphereHaze(w, uSunDir, uSunColor), c, air);
    sun *= air;
    fColor = vec4(c, 1.0);
    fSunLight = vec4(sun, 1.0);
}
