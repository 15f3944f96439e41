// Box fog (fogbank): density rho (1/m) times the product over the box's axes of the ramps
// clamp((h_i - |p_i|) / F, 0, 1) (F = 0: rho inside, a hard box), p the point in the box's
// frame: centre c (m, relative to the renderer's reference point), unit axes ax, ay, az,
// half extents h (m), F the edge fade's depth (m). w unit, d in m.

// The ray O + w s in the box's frame: (origin, direction).
void boxFrame(vec3 O, vec3 w, vec3 c, vec3 ax, vec3 ay, vec3 az, out vec3 o, out vec3 v) {
    vec3 q = O - c;
    o = vec3(dot(q, ax), dot(q, ay), dot(q, az));
    v = vec3(dot(w, ax), dot(w, ay), dot(w, az));
}

// The chord of o + v s, s in [0, d], inside |p_i| <= h_i (slab method, Kay & Kajiya 1986):
// (s0, s1, m) with s0, s1 relative to m, the parameter of the ray's closest approach to
// the centre, so that a thin box far away keeps its length's digits (its entry and exit,
// 1e4 m each, are not subtracted); s1 <= s0 where there is none.
vec3 boxChord(vec3 o, vec3 v, vec3 h, float d) {
    float m = -dot(o, v);                 // v is a unit vector (a rotated unit w)
    vec3 oc = o + v * m;
    float s0 = -m, s1 = d - m;
    for (int i = 0; i < 3; ++i) {
        // A direction exactly parallel to a pair of faces: the ray is between them all
        // along, or never. (1 / 0 would be inf, and (h - o) * inf NaN when o = h.)
        if (v[i] == 0.0) {
            if (abs(oc[i]) > h[i]) return vec3(1.0, 0.0, m);
            continue;
        }
        float inv = 1.0 / v[i];
        float ta = (-h[i] - oc[i]) * inv, tb = (h[i] - oc[i]) * inv;
        s0 = max(s0, min(ta, tb));
        s1 = min(s1, max(ta, tb));
    }
    return vec3(s0, s1, m);
}

// The ramps' product at oc + v t (the box's frame).
float boxFade(vec3 oc, vec3 v, float t, vec3 h, float F) {
    vec3 r = clamp((h - abs(oc + v * t)) / F, 0.0, 1.0);
    return r.x * r.y * r.z;
}

// Box fog's optical depth along O + w s, s in [0, d]. With a fade, each ramp is linear in s
// between its kinks (|p_i| = h_i - F and = h_i), so their product is a cubic between
// consecutive kinks: the kinks within the chord, sorted, and Simpson's rule on each piece
// (exact for a cubic) give the integral exactly.
float boxOpticalDepth(vec3 O, vec3 w, float d, vec3 c, vec3 ax, vec3 ay, vec3 az, vec3 h,
                      float F, float rho) {
    vec3 o, v;
    boxFrame(O, w, c, ax, ay, az, o, v);
    vec3 ch = boxChord(o, v, h, d);
    if (ch.y <= ch.x) return 0.0;
    if (F <= 0.0) return rho * (ch.y - ch.x);
    vec3 oc = o + v * ch.z;               // parameters t below are relative to the closest approach
    float k[14];
    k[0] = ch.x;
    int n = 1;
    for (int i = 0; i < 3; ++i) {
        if (v[i] == 0.0) continue;        // a ramp constant along the ray: no kink
        for (int j = 0; j < 4; ++j) {
            float b = (j < 2 ? h[i] : h[i] - F) * ((j & 1) == 0 ? 1.0 : -1.0);
            float t = clamp((b - oc[i]) / v[i], ch.x, ch.y);
            // insertion: keep k[0..n) sorted
            int at = n;
            while (at > 0 && k[at - 1] > t) { k[at] = k[at - 1]; --at; }
            k[at] = t;
            ++n;
        }
    }
    k[n] = ch.y;
    float sum = 0.0;
    for (int i = 0; i < n; ++i) {
        float a = k[i], b = k[i + 1];
        sum += (b - a) * (boxFade(oc, v, a, h, F) + 4.0 * boxFade(oc, v, 0.5 * (a + b), h, F)
                          + boxFade(oc, v, b, h, F));
    }
    return rho * sum / 6.0;
}

// A carving box's shell k of `shells` (nested boxes inset by (k + 1/2) / shells of the fade
// depth F; the box itself without one): its chord along O + w s, s in [0, d], as absolute
// parameters (s0, s1) (s1 <= s0: none).
vec2 boxShellChord(vec3 O, vec3 w, float d, vec3 c, vec3 ax, vec3 ay, vec3 az, vec3 h, float F,
                   int k, int shells) {
    vec3 o, v;
    boxFrame(O, w, c, ax, ay, az, o, v);
    vec3 ch = boxChord(o, v, max(h - F * (float(k) + 0.5) / float(shells), vec3(0.0)), d);
    // an end clipped to the segment's is the segment's own, exactly (back from relative to
    // the closest approach, d - m + m would be off by m's rounding: a sliver of fog kept)
    return vec2(ch.x <= -ch.z ? 0.0 : ch.x + ch.z, ch.y >= d - ch.z ? d : ch.y + ch.z);
}

// Its density at x (1/m), for the raymarched comparison.
float boxDensity(vec3 x, vec3 c, vec3 ax, vec3 ay, vec3 az, vec3 h, float F, float rho) {
    vec3 q = x - c;
    vec3 p = abs(vec3(dot(q, ax), dot(q, ay), dot(q, az)));
    if (F <= 0.0) return all(lessThanEqual(p, h)) ? rho : 0.0;
    vec3 r = clamp((h - p) / F, 0.0, 1.0);
    return rho * r.x * r.y * r.z;
}

// A carving box's share of the fog it removes at x (in [0, 1], times its strength): the
// share of its shells (boxShellChord) that hold x, for the raymarched comparison.
float boxCarveShare(vec3 x, vec3 c, vec3 ax, vec3 ay, vec3 az, vec3 h, float F) {
    vec3 q = x - c;
    vec3 p = abs(vec3(dot(q, ax), dot(q, ay), dot(q, az)));
    int shells = F > 0.0 ? CARVE_SHELLS : 1;
    float n = 0.0;
    for (int k = 0; k < shells; ++k)
        n += float(all(lessThanEqual(p, h - F * (float(k) + 0.5) / float(shells))));
    return n / float(shells);
}
