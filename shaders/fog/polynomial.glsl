// Biri 2002, 3.2.2: P(u) = sum c_i u^i on [-C, C], tiled (repeat) or zero outside,
// u = a . x + b. The running integral G(u) of the tiled P is n * (Q(C) - Q(-C)) + Q(r),
// r = u - 2 C n in [-C, C), Q the antiderivative with Q(0) = 0 (coefficients q[1..8],
// passed ready: q[i+1] = c_i / (i+1)).

float polyEval(float u, vec4 c0, vec4 c1) {  // Horner, c0 = coefficients 0..3, c1 = 4..7
    return c0.x + u * (c0.y + u * (c0.z + u * (c0.w + u * (c1.x + u * (c1.y + u * (c1.z + u * c1.w))))));
}

float polyAntideriv(float u, vec4 q0, vec4 q1) {  // Q(u) = sum q[i+1] u^(i+1)
    return u * polyEval(u, q0, q1);
}

// Tiled P at u: r in [-C, C) for repeat; 0 outside [-C, C] for zero mode.
float polyTiled(float u, float C, bool repeatMode, vec4 c0, vec4 c1) {
    if (repeatMode) return polyEval(u - 2.0 * C * floor((u + C) / (2.0 * C)), c0, c1);
    return (u < -C || u > C) ? 0.0 : polyEval(u, c0, c1);
}

float polyRunning(float u, float C, bool repeatMode, float period, vec4 q0, vec4 q1) {
    if (repeatMode) {
        float n = floor((u + C) / (2.0 * C));
        return n * period + polyAntideriv(u - 2.0 * C * n, q0, q1);
    }
    return polyAntideriv(clamp(u, -C, C), q0, q1);
}

// tau / density along O + w s, s in [0, d]: (G(u1) - G(u0)) / (a . w).
float polynomialOpticalDepth(vec3 O, vec3 w, float d, vec3 a, float b, float C, bool repeatMode,
                             float period, vec4 c0, vec4 c1, vec4 q0, vec4 q1) {
    float u0 = dot(a, O) + b;
    float du = dot(a, w) * d;
    // shift both ends by whole periods so G(u1) - G(u0) does not cancel against a large G
    if (repeatMode) u0 -= 2.0 * C * floor((u0 + C) / (2.0 * C));
    // |du| < 1e-3 C: float32 cancellation in G(u1) - G(u0) (~1e-7 C / du relative) would
    // beat the midpoint rule's error (du^2 P'' d / 24), so the midpoint rule is used
    if (abs(du) < 1e-3 * C) return d * polyTiled(u0 + 0.5 * du, C, repeatMode, c0, c1);
    float G0 = polyRunning(u0, C, repeatMode, period, q0, q1);
    float G1 = polyRunning(u0 + du, C, repeatMode, period, q0, q1);
    return (G1 - G0) * d / du;
}

// P at x (tiled or zero outside), times nothing: the caller weights it by the density.
float polynomialDensity(vec3 x, vec3 a, float b, float C, bool repeatMode, vec4 c0, vec4 c1) {
    return polyTiled(dot(a, x) + b, C, repeatMode, c0, c1);
}
