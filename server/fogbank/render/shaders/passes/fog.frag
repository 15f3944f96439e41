// The fog pass (Biri 4.1, 4.2): per texel of the fog target (1/FOG_SCALE of the frame,
// FOG_SCALE = 1, 2 or 4 defined by the renderer), rebuild the visible point from the
// G-buffer and integrate the fog along eye -> point. Writes the raw transmittance (the
// composite applies global density and max opacity, after the particle quads have
// multiplied theirs in), the inverse distance used, for the depth-aware upsample, and,
// with SUN_THROUGH_FOG, the transmittance from the visible point toward the sun (1 for the
// sky and without it).
#include "fog/transmittance.glsl"
#include "common/camera.glsl"
#include "passes/fog_texel.glsl"
in vec2 vUV;
uniform sampler2D uInvDist;       // full-resolution 1/distance (1/m), 0 = sky
uniform vec3 uFwd, uRight, uUp;   // camera basis, right/up scaled by tan(fov/2)
uniform float uSkyDistance;       // m
uniform vec3 uSunDir;             // unit, toward the sun
layout(location = 0) out vec3 fOut;  // (raw T, 1/distance used, T toward the sun)
void main() {
    FogTexel ft = fogTexel(gl_FragCoord.xy, uInvDist, uFwd, uRight, uUp);
    float d = ft.invd > 0.0 ? 1.0 / ft.invd : uSkyDistance;
    float sunT = 1.0;
#ifdef SUN_THROUGH_FOG
    if (ft.invd > 0.0) sunT = fogSunTransmittance(ft.w * d, uSunDir, uSkyDistance);
#endif
    fOut = vec3(fogRawTransmittance(vec3(0.0), ft.w, d), ft.invd, sunT);
}
