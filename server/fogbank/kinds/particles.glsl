// Fischer, "Clouds, Fog, and Smoke": one particle at p (m) of radius R (m: R_j, grown
// with its age, kinds/particles.py radii), strength s
// (remaining life / initial life) and max opacity alpha, seen along the segment
// O -> O + w d. Its opacity is alpha s clamp(1 - dist / R, 0, 1) and its clarity (its
// transmittance) 1 - opacity, dist the distance from p to the segment (Bourke: project
// onto the line, clamp to [0, d]). The caller takes -log(clarity) by directDepth(): a
// faint particle's clarity 1 - 4e-6 keeps only two digits of its opacity in float32.
float particleOpacity(vec3 O, vec3 w, float d, vec3 p, float R, float s, float alpha) {
    vec3 rel = p - O;
    float u = clamp(dot(rel, w), 0.0, d);
    float dist = length(rel - u * w);
    return alpha * s * clamp(1.0 - dist / R, 0.0, 1.0);
}
