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

// Where the quadrature of c cells starts among a light texel's coarser ones: Σ (2k)², k < c
// (math::lights::coarse_offset).
uint coarse_offset(uint c) {
    return 2u * (c - 1u) * c * (2u * c - 1u) / 3u;
}

// The squared scale of a lobe of scale `lobe` at a light texel `e` = axis − centre away:
// the lobe's own near the axis, TAIL_FRACTION of the chord in the tail (math::lights).
float light_scale2(float lobe, vec3 e) {
    return max(lobe * lobe, LIGHT_TAIL_FRACTION * LIGHT_TAIL_FRACTION * dot(e, e));
}

// Whether a light texel of angular size `rho` takes its centre alone where the kernel's
// squared scale is `w2` (PER_WIDTH·ρ < CENTRE_BELOW·w), or has no nodes (`stride`).
bool light_centre_only(float rho, float w2, uint stride) {
    float c = LIGHT_PER_WIDTH * rho / LIGHT_CENTRE_BELOW;
    return stride == LIGHT_HEADER_VEC4S || c * c < w2;
}

// Whether a light tree node (centre.xyz, reach in .w; its power's luminance `lum`) is taken
// whole by a kernel of scale `scale` about r whose cut plane has normal `cut`, fading as
// cos^fade towards it, a node allowed an error `allowance` (math::light_tree::takes_whole).
bool light_tree_whole(vec4 node, float lum, vec3 r, float scale, vec3 cut, float allowance,
                      float fade) {
    float far = max(length(r - node.xyz) - node.w, 0.0);
    float w = max(scale, LIGHT_TREE_TAIL * far);
    float q = node.w / w;
    float height = abs(dot(cut, node.xyz));
    bool clear = height > node.w;
    if (clear && q < LIGHT_TREE_BELOW) return true;
    // math::light_tree::kernel_bound
    float s2 = scale * scale, d = s2 + 0.25 * far * far;
    float e = lum * s2 / (PI * d * d);
    // math::light_tree::horizon_share (its argument is positive: a node's reach is)
    e *= clear ? q * q * q * q : pow(min(2.0 * (height + node.w) / scale, 1.0), fade);
    return q < LIGHT_TREE_BUDGET_REACH && e <= allowance;
}
#endif
