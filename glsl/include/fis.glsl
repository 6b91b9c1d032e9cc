// Filtered importance sampling's lod rule, twin of math::fis::sample_lod (shade.frag's fis()
// and prefilter_ggx.comp both read the dual-paraboloid chain by it).
#ifndef ENVLIGHT_FIS_GLSL
#define ENVLIGHT_FIS_GLSL

// Solid angle of a level-0 texel at d of a paraboloid `size` a side: 4/(1+s²+t²)² · (2/size)²,
// and 1+s²+t² = 2/(1+|d.y|).
float dp_texel_solid_angle(vec3 d, uint size) {
    float k = 2.0 / float(size), y1 = 1.0 + abs(d.y);
    return y1 * y1 * k * k;
}

// ½·log2(Ωs/Ωp) + bias, Ωs = 1/(N·pdf), clamped to [0, max_lod]; the last level where pdf is 0.
float fis_lod(float pdf, uint count, vec3 d, uint size, float bias, float max_lod) {
    if (pdf <= 0.0) return max_lod;
    float omega_s = 1.0 / (float(count) * pdf);
    return clamp(0.5 * log2(omega_s / dp_texel_solid_angle(d, size)) + bias, 0.0, max_lod);
}

#endif
