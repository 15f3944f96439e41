// Perlin fog write-up: a baked, tiling fractal-noise texture n(x) in [0, 1].
// Trilinear interpolation is done here with texelFetch rather than by the sampler:
// hardware filtering weights have as few as 8 bits on many GPUs (llvmpipe too), an
// error of up to 1/512 of a texel step that the float64 reference would see.
// x in m (relative to the reference point), invScale = tiles per metre, off = the
// reference point's position in tiles (wind slide included), reduced to [0, 1) in float64
// on the CPU. Texel centres at (i + 0.5) / N, as in GL.
//
// Filtered with distance in frames: a fog texel at distance |x| spans |x| uNoiseFootprint
// metres (the angle one fog texel subtends, set by the fog pass; 0 in the transmittance
// API, whose rays are not pixels). Where that is more than one noise texel, the tile's mip
// pyramid (box-filtered, wrapping) gives the average the pixel covers, at the level whose
// texels are that wide: distant noise no longer speckles. Nearer, the exact trilinear.
// A sample on a surface (`grazing`): the pixel's footprint on ground seen at a low angle is
// longer along the view by 1 / sin of that angle; the ground is taken as level (its slope is
// not known here), the angle as the view ray's elevation, at least 3 degrees (0.05): far
// hills speckled where the footprint was taken round.
uniform float uNoiseFootprint;            // rad per fog texel

float noiseSample(sampler3D tex, vec3 x, float invScale, vec3 off, bool grazing) {
    int n = textureSize(tex, 0).x;
    float N = float(n);
    vec3 t = x * invScale;
    t -= floor(t);                            // whole tiles first: keeps the sum below small
    float dist = length(x);
    // the footprint's two axes are 1 and `stretch` pixels' worth; one isotropic mip level
    // can only be their geometric mean (the long axis alone over-blurs across: 0.017 RMS
    // against the supersampled ground at 20-50 m, against 0.011 round and 0.012 here)
    float stretch = grazing ? sqrt(dist / max(abs(x.y), 0.05 * dist)) : 1.0;
    float texels = dist * uNoiseFootprint * invScale * N * stretch;
    if (texels > 1.0) return textureLod(tex, fract(t + off), log2(texels)).r;
    vec3 p = fract(t + off) * N - 0.5;
    p -= N * floor(p / N);                    // wrap into [0, N) before taking integers
    vec3 f = fract(p);
    ivec3 i0 = ivec3(floor(p)) % n;
    ivec3 i1 = (i0 + 1) % n;                  // both non-negative, so % is well defined
    float c000 = texelFetch(tex, ivec3(i0.x, i0.y, i0.z), 0).r;
    float c100 = texelFetch(tex, ivec3(i1.x, i0.y, i0.z), 0).r;
    float c010 = texelFetch(tex, ivec3(i0.x, i1.y, i0.z), 0).r;
    float c110 = texelFetch(tex, ivec3(i1.x, i1.y, i0.z), 0).r;
    float c001 = texelFetch(tex, ivec3(i0.x, i0.y, i1.z), 0).r;
    float c101 = texelFetch(tex, ivec3(i1.x, i0.y, i1.z), 0).r;
    float c011 = texelFetch(tex, ivec3(i0.x, i1.y, i1.z), 0).r;
    float c111 = texelFetch(tex, ivec3(i1.x, i1.y, i1.z), 0).r;
    return mix(mix(mix(c000, c100, f.x), mix(c010, c110, f.x), f.y),
               mix(mix(c001, c101, f.x), mix(c011, c111, f.x), f.y), f.z);
}
