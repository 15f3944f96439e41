// One particle at this fog texel, drawn with dual-source blending (src0 + dst src1): its
// clarity c multiplied into the raw T (glBlendFunc(ONE, SRC1_COLOR), src0.r = 0, src1.r
// = c), the inverse distance and T toward the sun kept (src1 = 1), and its light
// composited over the fog's in-scattered sunlight J (alpha): J' = c J + (1 - c) X. The
// particles come farthest first (kinds/particles.py pack), so each one's light is dimmed
// by the particles in front of it and dims those behind. With LIGHT, X is what the
// fog scatters in front of the particle plus the particle's own light behind that fog:
//   X = A(u) S(u) + (1 - A(u)) L,
// u the particle's distance along the ray (its closest approach, as its clarity takes
// it), (S, A) the light grid's share and opacity there (fog/light_grid.glsl) and L the
// particle's share of the sunlight (passes/particles.vert). Then J' is exactly the light of
// fog cut by the particle at u: the fog in front (A S) is not dimmed by c, the fog behind
// is. Without LIGHT, X = 1 and J stays 1 - T.
// The same particleOpacity() as the fog transmittance, on the same segment (start and
// cutoff distances applied).
#include "common/camera.glsl"
#include "common/math.glsl"
#include "kinds/particles.glsl"
#include "passes/fog_texel.glsl"
#if LIGHT
#include "fog/light_grid.glsl"
#endif
flat in vec4 vParticle;
flat in float vLight;
flat in float vRadius;            // m (passes/particles.vert)
uniform sampler2D uInvDist;
uniform vec3 uFwd, uRight, uUp;
uniform float uSkyDistance;
uniform float uStartDistance;
uniform float uCutoffDistance;
uniform float uAlpha;
uniform float uDensity;           // global density: clarity -> clarity^density
layout(location = 0, index = 0) out vec4 fColor;
layout(location = 0, index = 1) out vec4 fFactor;
void main() {
    FogTexel ft = fogTexel(gl_FragCoord.xy, uInvDist, uFwd, uRight, uUp);
    float d = ft.invd > 0.0 ? 1.0 / ft.invd : uSkyDistance;
    float c = 1.0;
    float X = 1.0;
    if (!(uCutoffDistance > 0.0 && d > uCutoffDistance)) {
        vec3 Os = ft.w * uStartDistance;   // relative to the eye, as the particles are
        float ds = max(d - uStartDistance, 0.0);
        // clarity^density, as exp(density log(1 - opacity)) (fog/transmittance.glsl)
        c = exp(-directDepth(particleOpacity(Os, ft.w, ds, vParticle.xyz, vRadius,
                                             vParticle.w, uAlpha), uDensity));
#if LIGHT
        float u = uStartDistance + clamp(dot(vParticle.xyz - Os, ft.w), 0.0, ds);
        vec2 SA = lightShare((floor(gl_FragCoord.xy) + 0.5) * float(uFogScale), u);
        X = SA.y * SA.x + (1.0 - SA.y) * vLight;
#endif
    }
    fColor = vec4(0.0, 0.0, 0.0, (1.0 - c) * X);
    fFactor = vec4(c, 1.0, 1.0, c);
}
