// Quilez, "analytically integrated volumetric media": density rho max(0, 1 - |x - c|^2/R^2)
// integrated along O + w s, s in [0, d], worked about the ray's closest approach to the
// centre. With q = c - O, b = q . w and h = |q x w| (the miss distance), x = O + w (b + t)
// has |x - c|^2 = h^2 + t^2, so the density is rho (a2 - t^2 / R^2), a2 = 1 - h^2/R^2, on
// the chord |t| <= R sqrt(a2). Its integral over [t0, t1] is
//   rho (t1 - t0) (a2 - (t0^2 + t0 t1 + t1^2) / (3 R^2)),
// the length times the mean density. Nothing in it grows with the distance to the sphere
// (the eye-centred form cancels like (D/R)^3), and h comes from a cross product, not from
// |q|^2 - b^2. O, c in m (relative to the renderer's reference point), w unit, rho in 1/m.
float sphereOpticalDepth(vec3 O, vec3 w, float d, vec3 c, float R, float rho) {
    vec3 q = c - O;
    float b = dot(q, w);
    vec3 x = cross(q, w);
    float invR2 = 1.0 / (R * R);
    float a2 = 1.0 - dot(x, x) * invR2;
    if (a2 <= 0.0) return 0.0;                // the line misses (or grazes) the sphere
    float a = R * sqrt(a2);                   // half chord, m
    // the chord is s in [b - a, b + a] along the ray; clip it to the segment [0, d]. The
    // length is taken in s, so a segment inside the sphere has length d exactly (in t it
    // would be (d - b) - (-b), which loses d's digits to b's when the centre is far)
    float s0 = max(b - a, 0.0);
    float s1 = min(b + a, d);
    if (s1 <= s0) return 0.0;
    float t0 = s0 - b, t1 = s1 - b;
    // the mean of a2 - t^2/R^2 over [t0, t1] is >= 0 there; max() only absorbs rounding
    return rho * (s1 - s0) * max(a2 - (t0 * t0 + t0 * t1 + t1 * t1) * invR2 / 3.0, 0.0);
}

// Its density rho max(0, 1 - |x - c|^2 / R^2) at x, for the raymarched comparison.
float sphereDensity(vec3 x, vec3 c, float R, float rho) {
    vec3 r = (x - c) / R;
    return rho * max(0.0, 1.0 - dot(r, r));
}
