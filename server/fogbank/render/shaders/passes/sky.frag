// Background of the scene pass: the sky (or a flat colour for the calibration scene),
// with inverse distance 0 ("infinitely far").
#include "common/camera.glsl"
#include "common/sky.glsl"
in vec2 vUV;
uniform vec3 uFwd, uRight, uUp;
uniform vec3 uSunDir;
uniform vec3 uSunColor;
uniform bool uFlatSky;
uniform vec3 uFlatSkyColor;
layout(location = 0) out vec4 fColor;
layout(location = 1) out float fInvDist;
layout(location = 2) out vec4 fSunLight;   // the direct sunlight of a surface: none here
void main() {
    vec3 w = viewRay(vUV * 2.0 - 1.0, uFwd, uRight, uUp);
    fColor = vec4(uFlatSky ? uFlatSkyColor : skyColor(w, uSunDir, uSunColor), 1.0);
    fInvDist = 0.0;
    fSunLight = vec4(0.0);
}
