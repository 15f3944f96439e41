// The last effect over the whole fog, applied to its transmittance T (every layer's, with
// the global density already inside: T = exp(-density tau) prod T_j^density): the max
// opacity, T never below 1 - max opacity (Unreal's FogMaxOpacity).
uniform float uMaxOpacity;

float fogFinish(float T) {
    return max(T, 1.0 - uMaxOpacity);
}
