// The countryside ground's albedo (linear) from the world position: grass with low-
// frequency variation, a gravel road along z = ROAD_Z, sandy river banks, rock on steep
// slopes. Constants mirror server/fogbank/terrain.py.
const float ROAD_Z = 0.0;
const float ROAD_HALF_WIDTH = 3.0;

float hash12(vec2 p) {  // Dave Hoskins' hash without sine, [0, 1)
    vec3 p3 = fract(vec3(p.xyx) * 0.1031);
    p3 += dot(p3, p3.yzx + 33.33);
    return fract((p3.x + p3.y) * p3.z);
}

float valueNoise(vec2 p) {
    vec2 i = floor(p), f = fract(p);
    vec2 u = f * f * (3.0 - 2.0 * f);
    return mix(mix(hash12(i), hash12(i + vec2(1, 0)), u.x),
               mix(hash12(i + vec2(0, 1)), hash12(i + vec2(1, 1)), u.x), u.y);
}

float riverX(float z) { return 10.0 + 22.0 * sin(z / 70.0); }

const float EXTENT = 220.0;   // the detailed terrain's half side (scene/terrain.py)

vec3 terrainAlbedo(vec3 p, vec3 n) {
    float v = valueNoise(p.xz * 0.05) * 0.6 + valueNoise(p.xz * 0.21) * 0.4;
    vec3 grass = mix(vec3(0.10, 0.19, 0.05), vec3(0.21, 0.29, 0.08), v);
    vec3 c = grass;
    // the river's banks, their edges widened to the pixel's footprint (fwidth) so that far
    // off they fade into the grass instead of breaking into dashes
    float dx = abs(p.x - riverX(p.z)), fw = fwidth(p.x - riverX(p.z));
    float bank = smoothstep(9.0 + fw, 6.5 - fw, dx) * clamp(2.5 / max(fw, 1e-3), 0.0, 1.0);
    c = mix(c, vec3(0.36, 0.31, 0.22), bank);
    // beyond the detailed land the coarse far land has no channel: the river's own width
    // takes the water's dark colour there, so that the river runs on to the horizon
    float far = step(EXTENT, max(abs(p.x), abs(p.z)));
    c = mix(c, vec3(0.03, 0.08, 0.10), far * smoothstep(7.5 + fw, 5.0 - fw, dx));
    // rock only beyond 50 degrees: grass holds the house's terrace banks (up to 46, cut
    // and filled in its slope, scene/terrain.py), which at 35-45 degrees read as grey
    // smudges; the hills never pass 35
    c = mix(c, vec3(0.26, 0.25, 0.23), smoothstep(0.64, 0.55, n.y));
    // road edge antialiased over one screen pixel
    float e = abs(p.z - ROAD_Z) - ROAD_HALF_WIDTH;
    float road = 1.0 - smoothstep(-fwidth(e), fwidth(e), e);
    vec3 gravel = vec3(0.30, 0.28, 0.25) * (0.9 + 0.2 * valueNoise(p.xz * 1.3));
    return mix(c, gravel, road);
}
