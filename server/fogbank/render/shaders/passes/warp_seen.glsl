// Where this frame's ray through a pixel crosses the warp base's image, a view from the same
// eye (render/reproject.py): a turn about the eye maps the image onto itself, the
// homography K R K^-1, whatever the depth. Shared by passes/warp.frag (the scene pass),
// warp_mask.frag (its mask alone) and warp_out.frag (a preview's finished frame).
#include "common/camera.glsl"
uniform vec3 uFwd, uRight, uUp;               // this frame's basis, right and up scaled by tan(fov/2) (right by the aspect too)
uniform vec3 uBaseFwd, uBaseRight, uBaseUp;   // the base's, alike

// The base's normalised device coordinates of the ray through uv (in [0, 1]^2), and
// whether the base saw it (in front, inside its image). w = fwd + x right + y up, scaled:
// x = (w . right) / |right|^2 / (w . fwd). 1e-6: a ray at right angles to the base's axis
// or behind it, which the base did not see.
vec2 baseNdc(vec2 uv, out bool seen) {
    vec3 w = viewRay(uv * 2.0 - 1.0, uFwd, uRight, uUp);
    float z = dot(w, uBaseFwd);
    vec2 ndc = vec2(dot(w, uBaseRight) / dot(uBaseRight, uBaseRight),
                    dot(w, uBaseUp) / dot(uBaseUp, uBaseUp)) / max(z, 1e-6);
    seen = z > 1e-6 && all(lessThanEqual(abs(ndc), vec2(1.0)));
    return ndc;
}

// The base's texel nearest that crossing, clamped to its image (a ray outside is drawn
// anew): within half a texel of its place, no blur, and no distance mixed across a
// silhouette, which would belong to neither surface.
ivec2 baseTexel(vec2 ndc, ivec2 size) {
    return clamp(ivec2(floor((ndc * 0.5 + 0.5) * vec2(size))), ivec2(0), size - 1);
}
