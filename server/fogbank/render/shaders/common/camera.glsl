// World-space view ray through a point of the screen. ndc in [-1, 1]^2; fwd, right, up
// the camera basis with right and up pre-scaled by tan(fov/2) (times the aspect for right).
vec3 viewRay(vec2 ndc, vec3 fwd, vec3 right, vec3 up) {
    return normalize(fwd + ndc.x * right + ndc.y * up);
}
