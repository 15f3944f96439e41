// OpenGL GL_EXP fog: constant density rho (1/m) over length d (m): tau = rho d.
float homogeneousOpticalDepth(float rho, float d) {
    return rho * d;
}

// Its density at any point (1/m), for the raymarched comparison.
float homogeneousDensity(float rho) {
    return rho;
}
