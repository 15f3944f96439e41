// Particle quads (Fischer's particles drawn as screen-space quads, so the cost follows
// the pixels a particle can touch rather than particles x pixels): one instance per
// particle, a quad over the screen bounds of its sphere of influence (its radius R_j, row 1
// of uParticles: kinds/particles.py radii). A pixel outside them has its segment farther
// than R_j from the particle: clarity 1 there.
// With LIGHT, also the particle's share of the sunlight: what the fog and the other
// particles leave of it (row 1 of uParticles, kinds/particle_light.py), times, with
// SHADOW, how much of the particle the scene's shadow map lights (weighted by uShafts).
uniform sampler2D uParticles;     // row 0: (x, y, z relative to the eye, strength); row 1: (sunlight share, R_j in m, 0, 0)
uniform vec3 uEye;                // m
uniform int uFirst;               // this layer's first particle
uniform mat4 uViewProj;
flat out vec4 vParticle;
flat out float vLight;
flat out float vRadius;           // m
#if SHADOW
uniform sampler2DShadow uShadow;  // the sun's depth map (compare: 1 = lit)
uniform mat4 uSunViewProj;        // world -> the sun's clip space
uniform float uShadowBiasScale;   // times the full map's bias
uniform float uShafts;            // how much the scene's shadows take from the sunlight in the fog

// the share of the particle's sphere the sun lights: its centre and four points half a
// radius out across the sun's view, each outside the map lit
float particleShadow(vec3 c, float R) {
    float lit = 0.0;
    for (int i = 0; i < 5; ++i) {
        vec2 o = i == 0 ? vec2(0.0) : 0.5 * R * vec2(i == 1 ? 1.0 : (i == 2 ? -1.0 : 0.0),
                                                           i == 3 ? 1.0 : (i == 4 ? -1.0 : 0.0));
        vec3 q = (uSunViewProj * vec4(c + vec3(o.x, 0.0, o.y), 1.0)).xyz * 0.5 + 0.5;
        bool inside = all(greaterThanEqual(q, vec3(0.0))) && all(lessThanEqual(q, vec3(1.0)));
        // 0.0015 of depth: as the light grid's samples (passes/light.frag)
        lit += inside ? texture(uShadow, vec3(q.xy, q.z - 0.0015 * uShadowBiasScale)) : 1.0;
    }
    return 1.0 - uShafts * (1.0 - lit / 5.0);
}
#endif

void main() {
    vec4 q = texelFetch(uParticles, ivec2(uFirst + gl_InstanceID, 0), 0);
    vParticle = q;
    vec2 lr = texelFetch(uParticles, ivec2(uFirst + gl_InstanceID, 1), 0).rg;
    vLight = lr.x;
    vRadius = lr.y;
#if SHADOW
    vLight *= particleShadow(uEye + q.xyz, vRadius);
#endif
    vec2 lo = vec2(1e9), hi = vec2(-1e9);
    bool behind = false;
    for (int i = 0; i < 8; ++i) {    // the corners of the sphere's bounding cube
        vec3 c = uEye + q.xyz + vRadius * vec3((i & 1) == 0 ? -1.0 : 1.0, (i & 2) == 0 ? -1.0 : 1.0,
                                        (i & 4) == 0 ? -1.0 : 1.0);
        vec4 clip = uViewProj * vec4(c, 1.0);
        // a corner at or behind the eye plane: the sphere may cover anything
        if (clip.w <= 1e-3) { behind = true; break; }
        lo = min(lo, clip.xy / clip.w);
        hi = max(hi, clip.xy / clip.w);
    }
    if (behind) { lo = vec2(-1.0); hi = vec2(1.0); }
    lo = clamp(lo, -1.0, 1.0);
    hi = clamp(hi, -1.0, 1.0);
    if (q.w <= 0.0) hi = lo;         // dead: an empty quad
    vec2 corner = vec2(gl_VertexID & 1, (gl_VertexID >> 1) & 1);
    gl_Position = vec4(mix(lo, hi, corner), 0.0, 1.0);
}
