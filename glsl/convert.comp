#version 460
// Resamples an environment map into another mapping. Each output texel is the solid-angle-
// weighted mean of ss x ss samples spread over its footprint (inside the disc for angular and
// paraboloid outputs), so minification filters instead of aliasing. Built twice: with SRC_CUBE
// the source is a cube view (hardware filtering crosses faces), otherwise a 2D array read with
// masked bilinear filtering that never touches texels outside the source's domain.
#extension GL_GOOGLE_include_directive : require
#include "mappings.glsl"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;

#ifdef SRC_CUBE
layout(set = 0, binding = BINDING_CONVERT_SRC) uniform samplerCube src_cube;
#else
layout(set = 0, binding = BINDING_CONVERT_SRC) uniform sampler2DArray src;
#endif
layout(set = 0, binding = BINDING_CONVERT_DST, rgba32f) uniform writeonly image2DArray dst;

layout(push_constant) uniform Push {
    vec4 world_to_file[3];
    uvec2 src_size;
    uvec2 dst_size;
    uint src_mapping;
    uint dst_mapping;
    uint ss;
    uint pad;
} pc;

vec3 sample_src(vec3 d) {
    vec3 f = vec3(dot(pc.world_to_file[0].xyz, d), dot(pc.world_to_file[1].xyz, d),
                  dot(pc.world_to_file[2].xyz, d));
#ifdef SRC_CUBE
    return textureLod(src_cube, f, 0.0).rgb;
#else
    Coord c = dir_to_coord(pc.src_mapping, f);
    ivec2 size = ivec2(pc.src_size);
    vec2 p = c.uv * vec2(size) - 0.5;
    ivec2 i0 = ivec2(floor(p));
    vec2 t = p - vec2(i0);
    vec3 acc = vec3(0.0);
    float wsum = 0.0;
    vec3 nearest = vec3(0.0);
    for (int k = 0; k < 4; k++) {
        ivec2 q = i0 + ivec2(k & 1, k >> 1);
        if (pc.src_mapping == MAPPING_LATLONG) {
            q.x = (q.x % size.x + size.x) % size.x;  // u wraps around the seam
        }
        q = clamp(q, ivec2(0), size - 1);
        float w = ((k & 1) == 1 ? t.x : 1.0 - t.x) * ((k >> 1) == 1 ? t.y : 1.0 - t.y);
        vec3 v = texelFetch(src, ivec3(q, int(c.layer)), 0).rgb;
        if (k == 0 || w > 0.25) nearest = v;
        if (!texel_in_domain(pc.src_mapping, pc.src_size, q)) continue;
        acc += w * v;
        wsum += w;
    }
    // Only at the very rim can every neighbour be outside the domain.
    return wsum > 0.0 ? acc / wsum : nearest;
#endif
}

void main() {
    uvec3 id = gl_GlobalInvocationID;
    if (any(greaterThanEqual(id.xy, pc.dst_size))) return;
    vec3 acc = vec3(0.0);
    float wsum = 0.0;
    float inv = 1.0 / float(pc.ss);
    for (uint b = 0u; b < pc.ss; b++) {
        for (uint a = 0u; a < pc.ss; a++) {
            Coord c;
            c.layer = id.z;
            c.uv = (vec2(id.xy) + (vec2(a, b) + 0.5) * inv) / vec2(pc.dst_size);
            float w = density(pc.dst_mapping, c.uv);
            if (w <= 0.0) continue;
            acc += w * sample_src(coord_to_dir(pc.dst_mapping, c));
            wsum += w;
        }
    }
    vec3 result = vec3(0.0);
    if (wsum > 0.0) {
        result = acc / wsum;
    } else if (pc.dst_mapping == MAPPING_DUAL_PARABOLOID) {
        // Outside the disc a paraboloid texel holds the continuation, so rim reads stay sane.
        Coord c;
        c.layer = id.z;
        c.uv = (vec2(id.xy) + 0.5) / vec2(pc.dst_size);
        result = sample_src(coord_to_dir(pc.dst_mapping, c));
    }
    imageStore(dst, ivec3(id), vec4(result, 1.0));
}
