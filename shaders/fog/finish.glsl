// Effects over the whole fog, applied to the raw transmittance T (the product of every
// layer's): the global density (T -> T^density, which scales every optical depth alike)
// and the max opacity (T never below 1 - max opacity; Unreal's FogMaxOpacity).
uniform float uDensityPow;
uniform float uMaxOpacity;

float fogFinish(float T) {
    // pow(0, 0) is undefined in GLSL; density 0 means no fog at all
    T = uDensityPow > 0.0 ? pow(T, uDensityPow) : 1.0;
    return max(T, 1.0 - uMaxOpacity);
}
