// Light in the fog (single scattering), on a coarse grid of view rays: its columns are
// the rays through the centres of blocks of uLightTile x uLightTile of the frame's
// pixels (render/passes/light.py). The sunlight scattered toward the eye from the first s
// metres of a ray is
//   J(s) = integral over u in [0, s] of -dT/du(u) T_sun(u) V(u) du,
// T(u) the fog's transmittance from the eye to u (exact: the closed forms from the eye,
// fog/transmittance.glsl), T_sun(u) the fog's transmittance from the point u toward the
// sun (exact, the same closed forms; LIT only, else 1), V(u) in [0, 1] whether the point
// sees the sun past the scene (the shadow map; weighted by uShafts: 1 - uShafts (1 - V)).
// -dT/du is T sigma for the density layers, and also the fade of the direct ones that
// are marched here (distance fog); particles are drawn as quads and lit there
// (passes/particles.frag). The phase function is constant along a ray (the sun is a
// direction), so the composite multiplies it in with the sun's colour.
//
// The ray is cut into N = SLICES slices ending at s_k (fog/light_grid.glsl
// lightSliceEnd). On each, T_sun is taken at one point and V averaged over SHADOW_TAPS
// points, both jittered by the column's interleaved gradient noise (fixed per column: a
// still camera's light holds still), and the slice's weight is exactly the share of the
// light it scatters, T(s_{i-1}) - T(s_i):
//   J(s_k) = sum over i <= k of (T(s_{i-1}) - T(s_i)) T_sun(x_i) V_i.
// Slice k stores (S_k, A_k) as two halves: A_k = 1 - T(s_k), the fog's opacity to s_k, and
// S_k = J(s_k) / A_k, the sunlit share of its in-scattering, in [0, 1]. A pixel's fog takes
// the share at its own distance (fog/light_grid.glsl lightShare), times its own exact
// opacity: the grid decides only how much of the fog's light is sunlit.
//
// LIGHT_STAGE (render/passes/light.py), as the fog pass's stages, for a camera that stays
// still while time runs:
//   0: one fragment a column marches its slices in order, SLICES / 4 RGBA32UI outputs of
//      four slices each (the atlas pass lays them side by side).
//   1: one fragment a froxel (slice k of column (i, j) at ((k - 1) columns + i, j)): what
//      the layers that do not change with time and the scene give it, held by later frames:
//      (tau and tauDirect from the eye to s_k, tau toward the sun from its point, V).
//   2: as 0, the moving layers' sums added to stage 1's.
//
// LIGHT_RAYS (render/rays.py, the light endpoint): instead of the grid, one fragment a ray
// of uRays (direction, length), as passes/rays.frag, marched over uSlices slices of its
// own length with each slice's median point (no jitter; in a dense slice found by
// bisection); it writes the light the composite would add along it
// (passes/composite_parts.glsl fogLight).
//
// Defined by the renderer: SLICES (a multiple of 4, at most 32), SHADOW_TAPS (0: no shadow
// map), LIT (0 or 1; with it SUN_THROUGH_FOG, for fogDepths toward the sun), LIGHT_STAGE.
#extension GL_ARB_shading_language_packing : require
#ifndef LIGHT_STAGE
#define LIGHT_STAGE 0
#endif
#include "fog/transmittance.glsl"
#include "common/camera.glsl"
#include "common/dither.glsl"
#define LIGHT_GRID_NO_LOOKUP 1
#include "fog/light_grid.glsl"
#ifdef LIGHT_RAYS
#define FOG_SCALE 1
#include "fog/finish.glsl"
// composite_parts declares uSunDir, uSkyDistance and the camera basis too
#include "passes/composite_parts.glsl"
#else
uniform vec3 uFwd, uRight, uUp;   // camera basis, right/up scaled by tan(fov/2)
uniform vec3 uSunDir;             // unit, toward the sun
uniform float uSkyDistance;       // m: how far a point's ray toward the sun runs
#endif
uniform int uSlices;              // SLICES, as a uniform: a constant trip count would unroll the loop
#if SHADOW_TAPS > 0
uniform sampler2DShadow uShadow;  // the sun's depth map (compare: 1 = lit)
uniform mat4 uSunViewProj;        // world -> the sun's clip space
uniform vec3 uEye;                // m, world (the shadow map is in world space)
uniform float uShadowBiasScale;   // times the full map's bias (render/resources.py ShadowMap.bias_scale)
uniform float uShafts;            // how much the scene's shadows take from the sunlight in the fog
#endif

#ifdef LIGHT_RAYS
uniform sampler2D uRays;          // (direction, length m) per ray, RAYS_PER_ROW a row
uniform int uFirst;               // this draw's rays: [uFirst, uFirst + uCount)
uniform int uCount;
layout(location = 0) out vec4 fRay;       // (T as /api/transmittance, J, T of the medium, 0)
layout(location = 1) out vec4 fLight;     // the fog's light along the ray, linear RGB
#elif LIGHT_STAGE == 1
layout(location = 0) out vec4 fHeld;      // (tau, tauDirect from the eye to s_k, tau toward the sun, V)
#else
#if LIGHT_STAGE == 2
uniform sampler2D uHeldLight;             // stage 1's froxels
#endif
layout(location = 0) out uvec4 fSlices0;
#if SLICES > 4
layout(location = 1) out uvec4 fSlices1;
#endif
#if SLICES > 8
layout(location = 2) out uvec4 fSlices2;
#endif
#if SLICES > 12
layout(location = 3) out uvec4 fSlices3;
#endif
#if SLICES > 16
layout(location = 4) out uvec4 fSlices4;
#endif
#if SLICES > 20
layout(location = 5) out uvec4 fSlices5;
#endif
#if SLICES > 24
layout(location = 6) out uvec4 fSlices6;
#endif
#if SLICES > 28
layout(location = 7) out uvec4 fSlices7;
#endif
#endif

// The fog's transmittance from its two sums from the eye (tau, tauDirect), as fogFromDepths
// without the cutoff distance: the medium itself, whose light a pixel beyond the cutoff
// shows all of ("fog") or none of ("clear").
float viewT(vec2 t) {
    return uDensity > 0.0 ? exp(-(max(t.x, 0.0) + t.y)) : 1.0;
}

// Where in a slice the share q of its scattered light has come from, as a fraction of its
// length: the inverse of 1 - e^(-dtau u) / (1 - e^(-dtau)), the light's distribution along
// a slice of optical depth dtau spread evenly over it. The light of a thin slice is spread
// evenly (q itself; below 1e-4 the two agree to 1e-5 of the slice), a dense one's comes from
// its first metres: its points for T_sun and V go where its light comes from, and a dense
// fog's sunlit skin is not missed by points deep in its shade.
float sliceQuantile(float q, float dtau) {
    return dtau < 1e-4 ? q : -log(1.0 - q * (1.0 - exp(-dtau))) / dtau;
}

#if SHADOW_TAPS > 0
// V of the slice [s0, s1] of the ray w: the share of SHADOW_TAPS points at the quantiles
// (t + j) / TAPS of its scattering (sliceQuantile, dtau its optical depth) that the sun
// lights. Past the surface a column's ray meets, its points lie under the ground (or in a
// tree) and in shade: a neighbouring pixel that sees farther takes some of that shade
// (the sky just above a hill, within one column). Counting them lit instead was further
// from the float64 integral at scene scale (tests/gl/test_light.py: mean |dJ| 0.0078 and
// 0.0104, against 0.0054), and looked the same.
float sliceVisibility(vec3 w, float s0, float s1, float j, float dtau) {
    // the sun's projection is orthographic (affine): a segment's points in the map's [0, 1]
    // space lie on the segment between its ends' images
    vec3 q0 = (uSunViewProj * vec4(uEye, 1.0)).xyz * 0.5 + 0.5;
    vec3 dq = (uSunViewProj * vec4(uEye + w, 1.0)).xyz * 0.5 + 0.5 - q0;   // per metre along w
    float lit = 0.0;
    for (int t = 0; t < SHADOW_TAPS; ++t) {
        float s = mix(s0, s1, sliceQuantile((float(t) + j) / float(SHADOW_TAPS), dtau));
        vec3 q = q0 + dq * s;
        // outside the map nothing casts a shadow; 0.0015 of depth keeps a point on a lit
        // surface from shadowing itself (as passes/scene.frag's bias, scaled for a
        // preview's coarser map)
        bool inside = all(greaterThanEqual(q, vec3(0.0))) && all(lessThanEqual(q, vec3(1.0)));
        lit += inside ? texture(uShadow, vec3(q.xy, q.z - 0.0015 * uShadowBiasScale)) : 1.0;
    }
    return 1.0 - uShafts * (1.0 - lit / float(SHADOW_TAPS));
}
#endif

// the slice's own jitter: the column's, stepped by the golden ratio's fraction so that the
// slices of one column do not all sample the same share of themselves
float sliceJitter(vec2 column, float k) {
    return fract(interleavedGradientNoise(column) + 0.6180340 * k);
}

// One slice [s0, s1] of the ray w: its weight T(s0) - T(s1), T from the sums t from the eye
// to s1 (plus, LIGHT_STAGE 2, what the held froxel adds), and the sunlight at its points,
// T_sun at the quantile jk and V at SHADOW_TAPS more (sliceQuantile of `dtau`, the slice's
// optical depth that places them: its own here, the time-invariant fog's for a held one),
// into the running sums J and W. Returns T(s1).
float slicePlaces(float T0, float T1) {
    return log(max(T0, 1e-30) / max(T1, 1e-30));   // 1e-30: an opaque T stays finite
}

float marchSlice(vec3 w, float s0, float s1, float jk, float T0, float far, vec4 held,
                 float heldDtau, inout float J, inout float W) {
    vec2 t = fogViewDepths(vec3(0.0), w, s1);
    float sunTau = 0.0, V = 1.0;
#if LIGHT_STAGE == 2 && !defined(LIGHT_RAYS)
    float dtau = heldDtau;
    t += held.xy;
    sunTau += held.z;
    V = held.w;
#endif
    float T1 = viewT(t);
#if LIGHT_STAGE != 2 || defined(LIGHT_RAYS)
    float dtau = slicePlaces(T0, T1);
#endif
    float u = mix(s0, s1, sliceQuantile(jk, dtau));
#ifdef LIGHT_RAYS
    // a ray's dense slice (its optical depth over 0.5): its fog need not be spread evenly (a
    // dense body's face, deep inside the slice), so the point is found where T has fallen by
    // the share jk of the slice's fall, by bisection of T along the slice (20 halvings: to a
    // millionth of the slice, finer than a dense body's sunlit skin)
    if (dtau > 0.5) {
        float target = T0 - jk * (T0 - T1), lo = s0, hi = s1;
        for (int i = 0; i < 20; ++i) {
            float mid = 0.5 * (lo + hi);
            if (viewT(fogViewDepths(vec3(0.0), w, mid)) > target) lo = mid; else hi = mid;
        }
        u = 0.5 * (lo + hi);
    }
#endif
#if LIT
    sunTau += fogDepths(w * u, uSunDir, uSkyDistance).x;
#endif
#if SHADOW_TAPS > 0 && (LIGHT_STAGE != 2 || defined(LIGHT_RAYS))
    V = sliceVisibility(w, s0, s1, jk, dtau);
#endif
    float sunT = uDensity > 0.0 ? exp(-max(sunTau, 0.0)) : 1.0;
    // the slice's weight, exactly the share of the light it scatters. 1e-6 of the slice's
    // share of the ray's length keeps S the length-weighted mean of T_sun V where there is
    // no fog (W would be 0), and moves it by at most 1e-6 / (1 - T) where there is.
    float wk = (T0 - T1) + 1e-6 * (s1 - s0) / far;
    J += wk * sunT * V;
    W += wk;
    return T1;
}

#ifdef LIGHT_RAYS
void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    int index = px.y * RAYS_PER_ROW + px.x;
    if (index < uFirst || index >= uFirst + uCount) discard;
    vec4 a = texelFetch(uRays, px, 0);
    vec3 w = normalize(a.xyz);
    float d = a.w, curve = max(d / LIGHT_CURVE_M, 1e-3);   // 1e-3: a ray of 0 m has no slices to space
    float s0 = 0.0, T0 = 1.0, J = 0.0, W = 0.0;
    for (int k = 1; k <= uSlices; ++k) {
        float s1 = sliceEnd(float(k), float(uSlices), d, curve);
        T0 = marchSlice(w, s0, s1, 0.5, T0, max(d, 1e-6), vec4(0.0), 0.0, J, W);
        s0 = s1;
    }
    J *= W > 0.0 ? (1.0 - T0) / W : 0.0;   // the march's J as a share of its weights, times the opacity
    float T = fogTransmittance(vec3(0.0), w, d);
    fRay = vec4(T, J, T0, 0.0);
    float invd = d > 0.0 ? 1.0 / d : 0.0;
    fLight = vec4(fogLight(T, fogRawTransmittance(vec3(0.0), w, d), J, scatterLobe(w, invd), fogAmbient(w, invd)), 0.0);
}
#elif LIGHT_STAGE == 1
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    int cols = int(uLightColumns.x);
    float k = float(p.x / cols + 1);                     // the slice, 1..N
    vec2 column = vec2(p.x % cols, p.y);
    vec3 w = lightColumnRay(column, uFwd, uRight, uUp);
    float s0 = lightSliceEnd(k - 1.0), s1 = lightSliceEnd(k), jk = sliceJitter(column, k);
    vec2 t = fogViewDepths(vec3(0.0), w, s1);
    // the held fog's own optical depth over the slice places its points (a frame of the
    // same fog over it places them alike)
    float dtau = slicePlaces(viewT(fogViewDepths(vec3(0.0), w, s0)), viewT(t));
    float sunTau = 0.0, V = 1.0;
#if LIT
    sunTau = fogDepths(w * mix(s0, s1, sliceQuantile(jk, dtau)), uSunDir, uSkyDistance).x;
#endif
#if SHADOW_TAPS > 0
    V = sliceVisibility(w, s0, s1, jk, dtau);
#endif
    fHeld = vec4(t, sunTau, V);
}
#else
void main() {
    vec2 column = floor(gl_FragCoord.xy);
    vec3 w = lightColumnRay(column, uFwd, uRight, uUp);
    uint slices[SLICES];
    float s0 = 0.0, T0 = 1.0, J = 0.0, W = 0.0;
    float heldT0 = 1.0;   // the held fog's own T to s0 (LIGHT_STAGE 2)
    for (int k = 1; k <= uSlices; ++k) {
        float s1 = lightSliceEnd(float(k));
        vec4 held = vec4(0.0);
        float heldDtau = 0.0;
#if LIGHT_STAGE == 2
        held = texelFetch(uHeldLight, ivec2((k - 1) * int(uLightColumns.x) + int(column.x), int(column.y)), 0);
        float heldT1 = viewT(held.xy);
        heldDtau = slicePlaces(heldT0, heldT1);
        heldT0 = heldT1;
#endif
        T0 = marchSlice(w, s0, s1, sliceJitter(column, float(k)), T0, uLightFar, held, heldDtau, J, W);
        slices[k - 1] = packHalf2x16(vec2(J / W, 1.0 - T0));
        s0 = s1;
    }
    fSlices0 = uvec4(slices[0], slices[1], slices[2], slices[3]);
#if SLICES > 4
    fSlices1 = uvec4(slices[4], slices[5], slices[6], slices[7]);
#endif
#if SLICES > 8
    fSlices2 = uvec4(slices[8], slices[9], slices[10], slices[11]);
#endif
#if SLICES > 12
    fSlices3 = uvec4(slices[12], slices[13], slices[14], slices[15]);
#endif
#if SLICES > 16
    fSlices4 = uvec4(slices[16], slices[17], slices[18], slices[19]);
#endif
#if SLICES > 20
    fSlices5 = uvec4(slices[20], slices[21], slices[22], slices[23]);
#endif
#if SLICES > 24
    fSlices6 = uvec4(slices[24], slices[25], slices[26], slices[27]);
#endif
#if SLICES > 28
    fSlices7 = uvec4(slices[28], slices[29], slices[30], slices[31]);
#endif
}
#endif
