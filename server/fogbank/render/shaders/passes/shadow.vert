// Depth from the sun's orthographic view, for the shadow map.
layout(location = 0) in vec3 aPos;
uniform mat4 uSunViewProj;
void main() { gl_Position = uSunViewProj * vec4(aPos, 1.0); }
