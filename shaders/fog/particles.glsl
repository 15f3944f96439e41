// Fischer, "Clouds, Fog, and Smoke": one particle at p (m) of radius R (m), strength s
// (remaining life / initial life) and max opacity alpha, seen along the segment
// O -> O + w d. Its clarity is 1 - alpha s clamp(1 - dist / R, 0, 1), dist the distance
// from p to the segment (Bourke: project onto the line, clamp to [0, d]).
float particleClarity(vec3 O, vec3 w, float d, vec3 p, float R, float s, float alpha) {
    vec3 rel = p - O;
    float u = clamp(dot(rel, w), 0.0, d);
    float dist = length(rel - u * w);
    return 1.0 - alpha * s * clamp(1.0 - dist / R, 0.0, 1.0);
}
