// Bakes the terrain's sun visibility (scene/sun_visibility.glsl) once per scene and sun,
// so that the scene pass reads one bilinear texel per terrain fragment instead of four
// shadow-map comparisons (about 30 of 100 ms of the 1280x720 scene pass on llvmpipe).
#include "scene/sun_visibility.glsl"
in vec3 vNormal;
in vec4 vSunPos;
layout(location = 0) out float fVisibility;
void main() {
    fVisibility = sunVisibility(vSunPos, normalize(vNormal));
}
