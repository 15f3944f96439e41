// The light grid's geometry and its lookup (render/passes/light.py, passes/light.frag).
// Needs common/camera.glsl.
// Its columns are the view rays through the centres of LIGHT_TILE x LIGHT_TILE blocks of
// the frame's pixels; each is cut into N slices whose ends grow geometrically,
//   s_k = far ((1 + c)^(k / N) - 1) / c,   k = 0..N,
// so that slices are about far / (20 N) ln(1 + c) long near the eye and longer far off
// (c = far / 20 m: render/passes/light.py LIGHT_CURVE_M). Slice k (1..N) of column (i, j)
// holds (S_k, A_k) at texel (i, j, k - 1) of the RG16F 3D texture uLightGrid.
uniform vec2 uLightFrame;         // the frame's size, px
uniform float uLightTile;         // px per column side
uniform vec2 uLightColumns;       // columns across and up
uniform float uLightSlices;       // N
uniform float uLightFar;          // m: s_N
uniform float uLightCurve;        // c, > 0

// s_k (m) for a slice coordinate k in [0, n] of slices ending geometrically at `far`, with c
// = `curve`
float sliceEnd(float k, float n, float far, float curve) {
    return far * (exp2(log2(1.0 + curve) * k / n) - 1.0) / curve;
}

// s_k of the grid's slices
float lightSliceEnd(float k) {
    return sliceEnd(k, uLightSlices, uLightFar, uLightCurve);
}

// the slice coordinate of a distance s >= 0 (m): lightSliceEnd's inverse
float lightSliceAt(float s) {
    return uLightSlices * log2(1.0 + uLightCurve * s / uLightFar) / log2(1.0 + uLightCurve);
}

// a column's ray (unit, world directions), `column` its whole coordinates
vec3 lightColumnRay(vec2 column, vec3 fwd, vec3 right, vec3 up) {
    return viewRay((column + 0.5) * uLightTile / uLightFrame * 2.0 - 1.0, fwd, right, up);
}

#ifndef LIGHT_GRID_NO_LOOKUP
uniform sampler3D uLightGrid;     // (S, A) of column (i, j), slice k at texel (i, j, k - 1), filtered LINEAR

// (S, A) at the frame's pixel position px (px, any point of the frame) and distance s (m):
// trilinear between the four nearest columns and the two slices round s, one filtered
// fetch. Before the first slice's end the share is its and the opacity grows from 0;
// beyond the last, both are the last's (the texture is clamped to its edge).
vec2 lightShare(vec2 px, float s) {
    float z = lightSliceAt(s);
    vec3 uvw = vec3(px / (uLightTile * uLightColumns), (clamp(z, 1.0, uLightSlices) - 0.5) / uLightSlices);
    vec2 v = texture(uLightGrid, uvw).rg;
    return vec2(v.x, v.y * min(z, 1.0));
}
#endif
