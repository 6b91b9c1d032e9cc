// Extracted light texels (src/math/lights.rs): split-sum's GGX kernel at n = v = r, shared by
// glsl/lights.comp (baked cubes) and glsl/shade.frag (split-sum materials).
#ifndef ENVLIGHT_LIGHTS_GLSL
#define ENVLIGHT_LIGHTS_GLSL

// math::split_sum::chain_kernel from the gap g = |r − l|²/2, with a2 = α²: D·G/4 with
// D = a2/(π s²) and G = 2x/(x + √(a2 + (1 − a2)x²)), folded into one division.
float chain_kernel(float a2, float g) {
    float x = 1.0 - g;
    if (x <= 0.0) return 0.0;
    float s = 0.5 * g + a2 * (1.0 - 0.5 * g);
    return a2 * x / (2.0 * PI * s * s * (x + sqrt(a2 + (1.0 - a2) * x * x)));
}
#endif
