// Marks the pixels that see two surfaces (the near surface's coverage below 1,
// passes/resolve.frag) in a one-byte target, read back once per held fog to list them
// (render/targets.py HeldFog.far_pixels): an eighth of the far colour's bytes.
uniform sampler2D uFarColor;      // the far surface's colour; a: the near surface's coverage
layout(location = 0) out float fTwo;

void main() {
    fTwo = texelFetch(uFarColor, ivec2(gl_FragCoord.xy), 0).a < 1.0 ? 1.0 : 0.0;
}
