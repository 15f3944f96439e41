// The fog pass (Biri 4.1, 4.2): per texel of the fog target (1/FOG_SCALE of the frame,
// FOG_SCALE = 1, 2 or 4 defined by the renderer), rebuild the visible point from the
// G-buffer and integrate the fog along eye -> point. The texel takes the nearest surface
// of its block (max inverse distance), and writes that inverse distance too, for the
// depth-aware upsample.
#include "fog/transmittance.glsl"
#include "common/camera.glsl"
in vec2 vUV;
uniform sampler2D uInvDist;       // full-resolution 1/distance (1/m), 0 = sky
uniform vec3 uEye;                // m
uniform vec3 uFwd, uRight, uUp;   // camera basis, right/up scaled by tan(fov/2)
uniform float uTime;              // s
uniform float uSkyDistance;       // m
layout(location = 0) out vec2 fOut;  // (T, 1/distance used)
void main() {
    ivec2 full = textureSize(uInvDist, 0);
    ivec2 base = ivec2(gl_FragCoord.xy) * FOG_SCALE;
    float invd = 0.0;
    for (int y = 0; y < FOG_SCALE; ++y)
        for (int x = 0; x < FOG_SCALE; ++x)
            invd = max(invd, texelFetch(uInvDist, min(base + ivec2(x, y), full - 1), 0).r);
    vec2 ndc = (vec2(base) + 0.5 * float(FOG_SCALE)) / vec2(full) * 2.0 - 1.0;
    vec3 w = viewRay(ndc, uFwd, uRight, uUp);
    float d = invd > 0.0 ? 1.0 / invd : uSkyDistance;
    fOut = vec2(fogTransmittance(uEye, w, d, uTime), invd);
}
