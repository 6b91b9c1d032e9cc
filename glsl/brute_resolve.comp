#version 460
// Brute-force convolution, step 4: one invocation per output texel adds its parts' sums
// (brute.comp) into the map.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#include "mappings.glsl"
#include "kernel.glsl"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = BINDING_BRUTE_RESOLVE_PARTIALS) readonly buffer Partials { vec4 partials[]; };
layout(set = 0, binding = BINDING_BRUTE_RESOLVE_DST, rgba32f) uniform writeonly image2DArray dst;

// The push block, generated from src/abi/push.rs.
PUSH_BrutePush

#include "brute.glsl"

// One invocation per output texel adds its parts' sums in part order (deterministic), each
// part's compensation too, and writes the texel.
void main() {
    uvec3 id = gl_GlobalInvocationID;
    if (any(greaterThanEqual(id.xy, pc.dst_size))) return;
    if (DST_MAPPING == MAPPING_ANGULAR && !texel_in_domain(DST_MAPPING, pc.dst_size, ivec2(id.xy))) {
        imageStore(dst, ivec3(id), vec4(0.0, 0.0, 0.0, 1.0));
        return;
    }
    uint o = (id.z * pc.dst_size.y + id.y) * pc.dst_size.x + id.x;
    uint parts = pc.parts.x * pc.parts.y;
    precise vec3 sum = partials[2u * o].rgb;
    precise vec3 comp = partials[2u * o + 1u].rgb;
    for (uint k = 1u; k < parts; k++) {
        uint e = 2u * (k * dst_texels() + o);
        kahan_add(sum, comp, partials[e].rgb);
        kahan_add(sum, comp, -partials[e + 1u].rgb);
    }
    imageStore(dst, ivec3(id), vec4(sum - comp, 1.0));
}
