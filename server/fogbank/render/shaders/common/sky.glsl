// A clear-sky gradient with a sun disk and glow, linear RGB. w: unit view direction,
// L: unit direction to the sun, sun: sun colour times intensity.
vec3 skyColor(vec3 w, vec3 L, vec3 sun) {
    float up = clamp(w.y, -1.0, 1.0);
    vec3 zenith = vec3(0.16, 0.32, 0.62);
    vec3 horizon = vec3(0.62, 0.70, 0.80);
    vec3 ground = vec3(0.30, 0.30, 0.28);
    vec3 c = up >= 0.0 ? mix(horizon, zenith, pow(up, 0.55)) : mix(horizon, ground, pow(-up, 0.4));
    float cosSun = max(dot(w, L), 0.0);
    c += sun * (0.05 * pow(cosSun, 8.0) + 0.25 * pow(cosSun, 180.0));
    c += sun * smoothstep(0.99985, 0.99995, cosSun);    // the disk, ~0.8 deg across
    return c;
}
