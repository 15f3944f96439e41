// Quilez, "analytically integrated volumetric media": density rho max(0, 1 - |x - s|^2/R^2)
// integrated along O + w s, s in [0, d], clipped to the sphere. Worked in the unit sphere
// for precision, then scaled by R back to metres. rho in 1/m, R and d in m.
float sphereOpticalDepth(vec3 O, vec3 w, float d, vec3 center, float R, float rho) {
    vec3 rc = (O - center) / R;
    float b = dot(w, rc);
    float c = dot(rc, rc) - 1.0;
    float h = b * b - c;
    if (h <= 0.0) return 0.0;                 // the line misses (or grazes) the sphere
    h = sqrt(h);
    float t1 = max(-b - h, 0.0);              // clip to the eye ...
    float t2 = min(-b + h, d / R);            // ... and to the visible surface
    if (t2 <= t1) return 0.0;
    // antiderivative of 1 - |rc + t w|^2 = -(c + 2 b t + t^2)
    float i1 = -(c * t1 + b * t1 * t1 + t1 * t1 * t1 / 3.0);
    float i2 = -(c * t2 + b * t2 * t2 + t2 * t2 * t2 / 3.0);
    return rho * R * (i2 - i1);
}

// Its density rho max(0, 1 - |x - s|^2 / R^2) at x, for the raymarched comparison.
float sphereDensity(vec3 x, vec3 center, float R, float rho) {
    vec3 r = (x - center) / R;
    return rho * max(0.0, 1.0 - dot(r, r));
}
