// One particle's clarity at this fog texel, multiplied into the fog target by blending
// (glBlendFunc(ZERO, SRC_COLOR)). The same particleOpacity() as the fog transmittance,
// on the same segment (start and cutoff distances applied).
#include "common/camera.glsl"
#include "common/math.glsl"
#include "kinds/particles.glsl"
#include "passes/fog_texel.glsl"
flat in vec4 vParticle;
uniform sampler2D uInvDist;
uniform vec3 uFwd, uRight, uUp;
uniform float uSkyDistance;
uniform float uStartDistance;
uniform float uCutoffDistance;
uniform float uRadius;
uniform float uAlpha;
uniform float uDensity;           // global density: clarity -> clarity^density
layout(location = 0) out vec4 fClarity;
void main() {
    FogTexel ft = fogTexel(gl_FragCoord.xy, uInvDist, uFwd, uRight, uUp);
    float d = ft.invd > 0.0 ? 1.0 / ft.invd : uSkyDistance;
    float c = 1.0;
    if (!(uCutoffDistance > 0.0 && d > uCutoffDistance)) {
        vec3 Os = ft.w * uStartDistance;   // relative to the eye, as the particles are
        float ds = max(d - uStartDistance, 0.0);
        // clarity^density, as exp(density log(1 - opacity)) (fog/transmittance.glsl)
        c = exp(-directDepth(particleOpacity(Os, ft.w, ds, vParticle.xyz, uRadius,
                                             vParticle.w, uAlpha), uDensity));
    }
    fClarity = vec4(c, 1.0, 1.0, 1.0);   // G (the inverse distance) is multiplied by 1
}
