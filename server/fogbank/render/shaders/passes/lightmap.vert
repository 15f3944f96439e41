// The terrain seen from above into the lightmap: each texel is the terrain's surface
// point over it (the height field has one), at its place on the mesh's own triangles.
layout(location = 0) in vec3 aPos;
layout(location = 1) in vec3 aNormal;
uniform mat4 uSunViewProj;
uniform vec4 uLightmapRect;   // x0, z0 (m) and 1 / the side (1/m): world x, z to [0, 1]
out vec3 vNormal;
out vec4 vSunPos;
void main() {
    vNormal = aNormal;
    vSunPos = uSunViewProj * vec4(aPos, 1.0);
    vec2 uv = (aPos.xz - uLightmapRect.xy) * uLightmapRect.zw;
    gl_Position = vec4(uv * 2.0 - 1.0, 0.0, 1.0);
}
