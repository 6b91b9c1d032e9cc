// Each texel's bounding cone, and the square root of a 2×2 covariance (brute_prepare.comp,
// brute_moments.comp).
#ifndef ENVLIGHT_BRUTE_CONES_GLSL
#define ENVLIGHT_BRUTE_CONES_GLSL
// The square root of a symmetric positive semi-definite 2×2 matrix (a, b, c) = [a b; b c].
vec3 sqrt2(vec3 m) {
    float d = sqrt(max(m.x * m.z - m.y * m.y, 0.0));
    float t = sqrt(m.x + m.z + 2.0 * d);
    return t > 0.0 ? vec3(m.x + d, m.y, m.z + d) / t : vec3(0.0);
}

// Texel p's centre direction (world) and the cosine of its angular radius: corners and edge
// midpoints (pulled into the disc), 25% wider for the bulge of the edges between them (twin of
// texel_cos_radius), for a texel of a pc.src_size map.
vec4 texel_cone(uint layer, ivec2 p) {
    vec3 c = src_dir(layer, (vec2(p) + 0.5) / vec2(pc.src_size));
    // Angular radius: corners and edge midpoints (pulled into the disc), 25% wider for the
    // bulge of the edges between them (twin of texel_cos_radius).
    bool disc = SRC_MAPPING == MAPPING_ANGULAR || SRC_MAPPING == MAPPING_DUAL_PARABOLOID;
    float min_dot = 1.0;
    for (int k = 0; k < 9; k++) {
        if (k == 4) continue;
        vec2 uv = (vec2(p) + 0.5 * vec2(k % 3, k / 3)) / vec2(pc.src_size);
        if (disc) {
            vec2 xy = 2.0 * uv - 1.0;
            float rr = length(xy);
            if (rr > 1.0) uv = 0.5 * (xy / rr + 1.0);
        }
        min_dot = min(min_dot, dot(c, src_dir(layer, uv)));
    }
    // acos via atan2 so a tiny radius keeps its digits.
    float md = clamp(min_dot, -1.0, 1.0);
    float rho = min(FILTER_CONE_MARGIN * atan2_precise(sqrt(max(0.0, (1.0 - md) * (1.0 + md))), md), PI);
    return vec4(c, cos(rho));
}
#endif
