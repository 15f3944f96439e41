// The transmittance endpoint: one fragment per ray, the same fogTransmittance() that
// draws frames. Rays are drawn in groups that share an origin and a time; the layers are
// packed relative to that origin (as a frame's are relative to its eye), so every ray
// starts at 0 here. uRays holds one texel per ray, (direction, length), RAYS_PER_ROW to a
// row; this draw covers rays [uFirst, uFirst + uCount).
#include "fog/transmittance.glsl"
uniform sampler2D uRays;
uniform int uFirst;
uniform int uCount;
layout(location = 0) out float fT;
void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    int index = px.y * RAYS_PER_ROW + px.x;
    if (index < uFirst || index >= uFirst + uCount) discard;
    vec4 a = texelFetch(uRays, px, 0);
    fT = fogTransmittance(vec3(0.0), normalize(a.xyz), a.w);
}
