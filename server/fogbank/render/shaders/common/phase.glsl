// Henyey & Greenstein 1941: the phase function p(theta) = (1 - g^2) /
// (4 pi (1 + g^2 - 2 g cos theta)^(3/2)), times 4 pi so that isotropic scattering (g = 0)
// is 1 in every direction; cosTheta is the cosine between the view ray and the direction
// toward the sun (so g > 0 brightens the fog looking toward the sun). Unitless.
// No epsilon guard: the model allows |g| <= 0.95, so the base is at least (1 - |g|)^2 =
// 0.0025 > 0 and the peak (1 + g) / (1 - g)^2 at most 780.
float phaseHG(float cosTheta, float g) {
    float denom = 1.0 + g * g - 2.0 * g * cosTheta;
    return (1.0 - g * g) / (denom * sqrt(denom));
}
