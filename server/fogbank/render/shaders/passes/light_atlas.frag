// The light grid's slices one above the other (render/passes/light.py), as a 3D texture
// holds them (slice k's rows k rows on): one draw per RGBA32UI output of passes/light.frag,
// over the rows of its four slices (uFirstSlice to uFirstSlice + 3), each texel the (S, A)
// halves of one slice of one column, unpacked to RG16F.
#extension GL_ARB_shading_language_packing : require
uniform usampler2D uSlices4;      // four slices a texel, one column a texel
uniform int uFirstSlice;          // the first of them, from 0
uniform int uColumnsY;            // columns up
layout(location = 0) out vec2 fShare;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    int k = p.y / uColumnsY;           // the slice, from 0
    uvec4 four = texelFetch(uSlices4, ivec2(p.x, p.y - k * uColumnsY), 0);
    fShare = unpackHalf2x16(four[k - uFirstSlice]);
}
