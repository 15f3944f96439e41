// Box fog, slab method (Kay & Kajiya 1986): constant density rho (1/m, negative carves)
// inside a box with centre c (m, relative to the renderer's reference point), unit axes
// ax, ay, az and half extents h (m). tau = rho * the length of O + w s, s in [0, d],
// inside the box: the ray's interval between each pair of parallel faces, intersected
// with [0, d]. w unit, d in m.
float boxOpticalDepth(vec3 O, vec3 w, float d, vec3 c, vec3 ax, vec3 ay, vec3 az, vec3 h,
                      float rho) {
    vec3 q = O - c;
    vec3 o = vec3(dot(q, ax), dot(q, ay), dot(q, az));   // the ray in the box's frame
    vec3 v = vec3(dot(w, ax), dot(w, ay), dot(w, az));
    float s0 = 0.0, s1 = d;
    for (int i = 0; i < 3; ++i) {
        // A direction exactly parallel to a pair of faces: the ray is between them all
        // along, or never. (1 / 0 would be inf, and (h - o) * inf NaN when o = h.)
        if (v[i] == 0.0) {
            if (abs(o[i]) > h[i]) return 0.0;
            continue;
        }
        float inv = 1.0 / v[i];
        float ta = (-h[i] - o[i]) * inv, tb = (h[i] - o[i]) * inv;
        s0 = max(s0, min(ta, tb));
        s1 = min(s1, max(ta, tb));
    }
    return rho * max(s1 - s0, 0.0);
}

// Its density at x (1/m), for the raymarched comparison.
float boxDensity(vec3 x, vec3 c, vec3 ax, vec3 ay, vec3 az, vec3 h, float rho) {
    vec3 q = x - c;
    vec3 p = abs(vec3(dot(q, ax), dot(q, ay), dot(q, az)));
    return all(lessThanEqual(p, h)) ? rho : 0.0;
}
