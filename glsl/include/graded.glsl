// The graded panels of the first uniform of the BRDF quadrature over the sampler's unit
// square, twin of math::sh_brdf::graded_panels (sh_brdf.comp and dfg.comp both integrate by it).
#ifndef ENVLIGHT_GRADED_GLSL
#define ENVLIGHT_GRADED_GLSL

// Panel k of 2·SH_BRDF_GRADED_LEVELS over [0, 1]: [0, 2⁻ᴶ], [2⁻ᴶ, 2¹⁻ᴶ], …, [¼, ½], then the
// same mirrored about ½.
vec2 lower_panel(uint k) {
    const uint J = SH_BRDF_GRADED_LEVELS;
    return vec2(k == 0u ? 0.0 : exp2(-float(J - k + 1u)), exp2(-float(J - k)));
}

vec2 graded_panel(uint k) {
    if (k < SH_BRDF_GRADED_LEVELS) return lower_panel(k);
    vec2 p = lower_panel(2u * SH_BRDF_GRADED_LEVELS - 1u - k);
    return vec2(1.0 - p.y, 1.0 - p.x);
}

#endif
