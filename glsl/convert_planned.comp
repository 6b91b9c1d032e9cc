#version 460
// Lat-long to cube or dual paraboloid by exact footprint areas, from a plan
// (math::convert::area_plan): per output texel, the source texels its footprint overlaps with
// the overlap's ∫∫ 1, ∫∫ (U − Uc) and ∫∫ (z − zc) over the footprint's area, so that the mean
// of the source's reconstruction (each texel's value plus its limited slopes,
// convert_slopes.comp) over the footprint is a sum of a few terms. convert_area.comp has the
// geometry; the plan holds its float64 result for a source size, an output mapping and size
// and an orientation. Twin: math::convert::apply_area_plan.
#extension GL_GOOGLE_include_directive : require
#include "mappings.glsl"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;

layout(set = 0, binding = BINDING_CONVERT_SRC) uniform sampler2DArray src;
layout(set = 0, binding = BINDING_CONVERT_DST, rgba32f) uniform writeonly image2DArray dst;
// (dL/dU rgb, 0) and (dL/dz rgb, 0) per source texel, through the buffers' texel views.
layout(set = 0, binding = BINDING_CONVERT_SLOPES_U) uniform samplerBuffer slopes_u;
layout(set = 0, binding = BINDING_CONVERT_SLOPES_Z) uniform samplerBuffer slopes_z;
layout(std430, set = 0, binding = BINDING_CONVERT_PLAN_OFFSETS) readonly buffer Offsets {
    uint offsets[];  // per output texel its first entry, then the entry count
};
layout(std430, set = 0, binding = BINDING_CONVERT_PLAN_ENTRIES) readonly buffer Entries {
    uvec4 entries[];  // (col | row << AREA_PLAN_ROW_SHIFT, area, mu, mz as float bits)
};

// The push block, generated from src/abi/push.rs.
PUSH_ConvertPush

void main() {
    uvec3 id = gl_GlobalInvocationID;
    if (any(greaterThanEqual(id.xy, pc.dst_size))) return;
    uint t = (id.z * pc.dst_size.y + id.y) * pc.dst_size.x + id.x;
    uint w = pc.src_size.x;
    // Summed with Kahan's compensation: a small texel's terms are a few, but a large one's
    // (a cube of side 1, with slivers of either sign) are hundreds, more than float32's
    // running sum holds to the twin's 5e-6.
    precise vec3 sum = vec3(0.0), lost = vec3(0.0);
    for (uint k = offsets[t]; k < offsets[t + 1u]; k++) {
        uvec4 e = entries[k];
        ivec2 cell = ivec2(e.x & ((1u << AREA_PLAN_ROW_SHIFT) - 1u), e.x >> AREA_PLAN_ROW_SHIFT);
        int o = int(uint(cell.y) * w + uint(cell.x));
        precise vec3 term = uintBitsToFloat(e.y) * texelFetch(src, ivec3(cell, 0), 0).rgb +
                            uintBitsToFloat(e.z) * texelFetch(slopes_u, o).xyz +
                            uintBitsToFloat(e.w) * texelFetch(slopes_z, o).xyz;
        precise vec3 y = term - lost;
        precise vec3 next = sum + y;
        lost = (next - sum) - y;
        sum = next;
    }
    imageStore(dst, ivec3(id), vec4(max(sum, vec3(0.0)), 1.0));
}
