// The transmittance endpoint: one fragment per ray, the same fogTransmittance() that
// draws frames. uRays holds two texels per ray: (origin, length) in row 2r, (direction,
// time) in row 2r + 1, for rays laid out RAYS_PER_ROW to a row.
#include "fog/transmittance.glsl"
uniform sampler2D uRays;
uniform int uRayCount;
layout(location = 0) out float fT;
void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    int index = px.y * RAYS_PER_ROW + px.x;
    if (index >= uRayCount) { fT = 1.0; return; }
    vec4 a = texelFetch(uRays, ivec2(px.x, 2 * px.y), 0);
    vec4 b = texelFetch(uRays, ivec2(px.x, 2 * px.y + 1), 0);
    fT = fogTransmittance(a.xyz, normalize(b.xyz), a.w, b.w);
}
