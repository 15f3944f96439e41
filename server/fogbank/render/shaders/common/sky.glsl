// The clear sky's colours, linear RGB: at the zenith, at the horizon, and of the land
// seen far below the horizon (a distant green under haze, where no mesh reaches).
const vec3 SKY_ZENITH = vec3(0.16, 0.32, 0.62);
const vec3 SKY_HORIZON = vec3(0.62, 0.70, 0.80);
const vec3 SKY_GROUND = vec3(0.19, 0.24, 0.16);

// The sky's gradient without the sun, w a unit direction: zenith to horizon above, horizon
// to the distant land below.
vec3 skyGradient(vec3 w) {
    float up = clamp(w.y, -1.0, 1.0);
    return up >= 0.0 ? mix(SKY_HORIZON, SKY_ZENITH, pow(up, 0.55)) : mix(SKY_HORIZON, SKY_GROUND, pow(-up, 0.4));
}

// The sky's colour as haze in the fog (the composite's aerial perspective), w a unit view
// direction: the gradient above the horizon (a downward ray's fog is lit by the sky above
// it: the horizon's colour), toward its mean over the upper hemisphere (up^0.55 averages
// 1 / 1.55 over the hemisphere's solid angle) as `far` goes from 1 to 0: a fog near the eye
// is lit by the whole sky, far off it takes the colour of the sky behind it.
// It is mean + far (horizon - mean) + far up^0.55 (zenith - horizon): skyHazeOf rebuilds it
// from (far, up^0.55) (a held composite keeps the two per pixel as bytes:
// passes/composite_inputs.frag).
const vec3 SKY_MEAN = mix(SKY_HORIZON, SKY_ZENITH, 1.0 / 1.55);

vec3 skyHazeOf(float far, float up055) {
    return SKY_MEAN + far * (SKY_HORIZON - SKY_MEAN) + (far * up055) * (SKY_ZENITH - SKY_HORIZON);
}

// up^0.55 of the unit direction w (0 below the horizon): the gradient's mix toward the zenith
float skyHazeUp(vec3 w) {
    return pow(max(w.y, 0.0), 0.55);
}

vec3 skyHaze(vec3 w, float far) {
    return skyHazeOf(far, skyHazeUp(w));
}

// A clear-sky gradient with a sun disk and glow, linear RGB. w: unit view direction,
// L: unit direction to the sun, sun: sun colour times intensity.
// The sun's glow (no disc) in a direction at cosSun >= 0 from it.
vec3 sunGlow(float cosSun, vec3 sun) {
    return sun * (0.05 * pow(cosSun, 8.0) + 0.25 * pow(cosSun, 180.0));
}

vec3 skyColor(vec3 w, vec3 L, vec3 sun) {
    vec3 c = skyGradient(w);
    float cosSun = max(dot(w, L), 0.0);
    c += sunGlow(cosSun, sun);
    c += sun * smoothstep(0.99985, 0.99995, cosSun);    // the disk, ~0.8 deg across
    return c;
}

// The air's own haze (aerial perspective, as the sky models of Preetham et al. 1999 and
// Hoffman & Preetham 2002 add to every surface): the air between the eye and a surface d
// metres off keeps exp(-d / ATMOSPHERE_M) of its light and adds that much less of the
// sky's colour just above the horizon in its direction (the gradient there and the sun's
// glow, no disc): a clear day's haze, 3 km to 1/e (a meteorological visibility of about
// 12 km). The land a few kilometres off pales toward the sky's colour where the two
// meet: the world's far edge stood as a hard green line against the sky (a clear look's
// land and sky within 1.3 degrees of the horizon differed by 159 levels of blue, now 78);
// at the detailed land's 220 m it keeps 93%. The fog layers lie over it
// (passes/composite.frag).
const float ATMOSPHERE_M = 3000.0;

vec3 atmosphereHaze(vec3 w, vec3 L, vec3 sun) {
    // the horizontal direction under w (1e-6: straight down, any horizontal will do)
    vec3 h = vec3(w.x, 0.0, w.z);
    float len = length(h);
    h = len > 1e-6 ? h / len : vec3(1.0, 0.0, 0.0);
    // the sky's gradient at the horizon is SKY_HORIZON itself (skyGradient, up = 0)
    return SKY_HORIZON + sunGlow(max(dot(h, L), 0.0), sun);
}
