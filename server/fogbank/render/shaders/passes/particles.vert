// Particle quads (Fischer's particles drawn as screen-space quads, so the cost follows
// the pixels a particle can touch rather than particles x pixels): one instance per
// particle, a quad over the screen bounds of its sphere of influence (radius R). A pixel
// outside them has its segment farther than R from the particle: clarity 1 there.
uniform sampler2D uParticles;     // (x, y, z relative to the eye, strength) per particle
uniform vec3 uEye;                // m
uniform int uFirst;               // this layer's first particle
uniform float uRadius;            // m
uniform mat4 uViewProj;
flat out vec4 vParticle;
void main() {
    vec4 q = texelFetch(uParticles, ivec2(uFirst + gl_InstanceID, 0), 0);
    vParticle = q;
    vec2 lo = vec2(1e9), hi = vec2(-1e9);
    bool behind = false;
    for (int i = 0; i < 8; ++i) {    // the corners of the sphere's bounding cube
        vec3 c = uEye + q.xyz + uRadius * vec3((i & 1) == 0 ? -1.0 : 1.0, (i & 2) == 0 ? -1.0 : 1.0,
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
