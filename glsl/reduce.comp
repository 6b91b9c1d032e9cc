#version 460
// Reduces a lat-long or cube map by `factor` per axis: each texel the solid-angle-weighted
// mean of its factor x factor source texels, so that the sum of L·Ω is kept. A conversion that
// minifies strongly reads this instead of the source (src/math/convert.rs: Sampling), at a
// rate set by the reduced size. Lat-long weights are the texels' closed-form solid angles;
// cube weights the density at the texel centre (exact to O(h²) within a block, as the twin).
#extension GL_GOOGLE_include_directive : require
#include "mappings.glsl"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(constant_id = 2) const uint MAPPING = 0u;
layout(set = 0, binding = BINDING_REDUCE_SRC) uniform sampler2DArray src;
layout(set = 0, binding = BINDING_REDUCE_DST, rgba32f) uniform writeonly image2DArray dst;

// The push block, generated from src/abi.rs.
PUSH_ReducePush

float weight(ivec2 q) {
    if (MAPPING == MAPPING_CUBE) {
        vec2 st = 2.0 * (vec2(q) + 0.5) / vec2(pc.src_size) - 1.0;
        float k = 1.0 + dot(st, st);
        return 1.0 / (k * sqrt(k));
    }
    return texel_solid_angle(MAPPING, pc.src_size, q);
}

void main() {
    uvec3 id = gl_GlobalInvocationID;
    if (any(greaterThanEqual(id.xy, pc.dst_size))) return;
    ivec2 base = ivec2(id.xy * pc.factor);
    vec3 acc = vec3(0.0);
    float wsum = 0.0;
    for (int y = 0; y < int(pc.factor); y++) {
        for (int x = 0; x < int(pc.factor); x++) {
            ivec2 q = base + ivec2(x, y);
            float w = weight(q);
            acc += w * texelFetch(src, ivec3(q, int(id.z)), 0).rgb;
            wsum += w;
        }
    }
    imageStore(dst, ivec3(id), vec4(acc / wsum, 1.0));
}
