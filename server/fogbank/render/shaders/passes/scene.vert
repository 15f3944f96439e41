// The scene's geometry: position (m), normal, albedo (linear), material id.
layout(location = 0) in vec3 aPos;
layout(location = 1) in vec3 aNormal;
layout(location = 2) in vec3 aColor;
layout(location = 3) in float aMaterial;
uniform mat4 uViewProj;
uniform mat4 uSunViewProj;
out vec3 vPos;
out vec3 vNormal;
out vec3 vColor;
out vec4 vSunPos;
flat out int vMaterial;
void main() {
    vPos = aPos;
    vNormal = aNormal;
    vColor = aColor;
    vMaterial = int(aMaterial + 0.5);
    vSunPos = uSunViewProj * vec4(aPos, 1.0);
    gl_Position = uViewProj * vec4(aPos, 1.0);
}
