// The sky's triangle: fullscreen, on the far plane (NDC z = 1, window depth 1.0), so
// that drawn after the scene with depth test <= it shades only the pixels no surface
// covered (the depth buffer is cleared to 1.0).
out vec2 vUV;
void main() {
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
    vUV = p;
    gl_Position = vec4(p * 2.0 - 1.0, 1.0, 1.0);
}
