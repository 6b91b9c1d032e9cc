// Filtered importance sampling's lod rule and chain lookup, twins of math::fis::sample_lod and
// math::fis::lookup (shade.frag's fis() and prefilter_ggx.comp both read the dual-paraboloid
// chain by them).
#ifndef ENVLIGHT_FIS_GLSL
#define ENVLIGHT_FIS_GLSL

#include "mappings.glsl"

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

// Radiance along d at lod from a premultiplied chain of `size`-texel halves (glsl/mip.comp),
// twin of math::fis::lookup: both halves read at d's coordinate continued past their rims,
// (s, t) = d.xz/(1 ± d.y), and added, so a footprint crossing the rim gathers both sides. The
// sampler reads transparent black beyond the image. The far half is skipped where its
// coordinate lies over 3 texels of the coarser level beyond its rim: a bilinear tap reaches
// at most 2.12 texels (√2 to the tap's centre, √2/2 across it), so the skip drops only zeros.
vec3 dp_chain_lookup(sampler2DArray chain, vec3 d, float lod, uint size, float max_lod) {
    Coord c = dir_to_coord(MAPPING_DUAL_PARABOLOID, d);
    vec4 v = textureLod(chain, vec3(c.uv, float(c.layer)), lod);
    float far_k = 1.0 - abs(d.y);
    if (far_k > 0.0) {
        vec2 st = d.xz / far_k;
        float texel = 2.0 / float(max(size >> uint(min(ceil(lod), max_lod)), 1u));
        if (length(st) - 1.0 < 3.0 * texel) {
            v += textureLod(chain, vec3(0.5 * st + 0.5, float(1u - c.layer)), lod);
        }
    }
    return v.a > 0.0 ? v.rgb / v.a : vec3(0.0);
}

#endif
