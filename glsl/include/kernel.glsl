// Convolution kernels of x = axis·ω (twin of src/math/filter.rs): the clamped cosine and the
// normalised Phong lobe, evaluated from the gap g = |axis − ω|²/2 = 1 − x, which keeps its
// digits near the peak where x itself rounds to 1.
#ifndef ENVLIGHT_KERNEL_GLSL
#define ENVLIGHT_KERNEL_GLSL

// ln(1 − g) for g in [0, 1): the series to g⁸ below 1/8 (error under 1e-9 relative), else log.
float log1m(float g) {
    if (g >= 0.125) return log(1.0 - g);
    return -g * (1.0 + g * (1.0 / 2.0 + g * (1.0 / 3.0 + g * (1.0 / 4.0 + g * (1.0 / 5.0
        + g * (1.0 / 6.0 + g * (1.0 / 7.0 + g * (1.0 / 8.0))))))));
}

// exponent == 0 selects the cosine (irradiance); otherwise (n+1)/2π·max(0, x)^n.
float kernel_eval(float exponent, vec3 axis, vec3 w) {
    vec3 e = axis - w;
    float g = 0.5 * dot(e, e);
    if (g >= 1.0) return 0.0;
    if (exponent == 0.0) return 1.0 - g;
    return (exponent + 1.0) / TAU * exp(exponent * log1m(g));
}
#endif
