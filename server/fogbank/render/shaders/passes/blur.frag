// Fog blur as separate passes (Gawron 3.4): a 1D Gaussian along uDirection whose sigma
// follows the fog amount stored in alpha, on the already foggy image. Nine taps at
// sigma/2 spacing cover +-2 sigma. Each reads the image's mip level whose texels are about
// sigma/2 wide (a box prefilter the width of the gap between taps): read from the full
// image, the taps' gaps showed a sharp edge as nine stripe-shaped copies once sigma was a
// few pixels (the house's bright wall at blur_radius 12). The second pass writes sRGB.
#include "common/srgb.glsl"
uniform sampler2D uImage;         // linear colour, alpha = 1 - T
uniform vec2 uDirection;          // (1, 0) or (0, 1)
uniform float uBlurSigma;         // px at full fog
uniform float uBlurExponent;
uniform bool uFinal;
layout(location = 0) out vec4 fColor;
void main() {
    vec2 size = vec2(textureSize(uImage, 0));
    vec2 px = gl_FragCoord.xy;
    vec4 centre = texelFetch(uImage, ivec2(px), 0);
    float sigma = uBlurSigma * pow(centre.a, uBlurExponent);
    vec3 c = centre.rgb;
    if (sigma > 0.05) {   // below 0.05 px the kernel is the identity to 8 bits
        vec3 acc = vec3(0.0);
        float wsum = 0.0;
        float lod = max(log2(0.5 * sigma), 0.0);
        for (int i = -4; i <= 4; ++i) {
            float w = exp(-0.125 * float(i * i));   // Gaussian at offset i sigma / 2
            acc += w * textureLod(uImage, (px + uDirection * float(i) * 0.5 * sigma) / size, lod).rgb;
            wsum += w;
        }
        c = acc / wsum;
    }
    fColor = uFinal ? vec4(outputColor(c, floor(px)), 1.0) : vec4(c, centre.a);
}
