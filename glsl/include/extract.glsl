// The GPU light extraction's records (passes::extract, EXTRACT_RECORD_VEC4S vec4s each),
// written by glsl/extract.comp and read by glsl/extract_add.comp.
#ifndef ENVLIGHT_EXTRACT_GLSL
#define ENVLIGHT_EXTRACT_GLSL

// (file-frame centre direction, ω), (excess rgb, luminance Y), (layer, i, j, 0).
struct Record {
    vec4 dir_omega;
    vec4 excess_y;
    uvec4 texel;
};
#endif
