#version 460
// One level of the pairwise tree over SH partial sums: workgroup g sums rows
// g*SH_WORKGROUP .. g*SH_WORKGROUP + SH_WORKGROUP - 1 of the input, coefficient by
// coefficient, into row g of the output.
#extension GL_GOOGLE_include_directive : require
#ifdef USE_SUBGROUPS
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_basic : require
#endif
#include "generated.glsl"

layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;

layout(std430, set = 0, binding = BINDING_SH_REDUCE_IN) readonly buffer In { float rows_in[]; };
layout(std430, set = 0, binding = BINDING_SH_REDUCE_OUT) writeonly buffer Out { float rows_out[]; };

// The push block, generated from src/abi/push.rs.
PUSH_ShReducePush

#ifdef USE_SUBGROUPS
shared vec3 sums[SH_WORKGROUP];
#else
shared vec3 tree[SH_WORKGROUP];
#endif

void main() {
    uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    uint tid = gl_LocalInvocationID.x;
    uint row = group * SH_WORKGROUP + tid;
    for (uint k = 0u; k < pc.coeffs; k++) {
        vec3 v = vec3(0.0);
        if (row < pc.rows) {
            uint o = (row * pc.coeffs + k) * 3u;
            v = vec3(rows_in[o], rows_in[o + 1u], rows_in[o + 2u]);
        }
#ifdef USE_SUBGROUPS
        vec3 s = subgroupAdd(v);
        if (subgroupElect()) sums[gl_SubgroupID] = s;
        barrier();
        if (tid == 0u) {
            vec3 t = vec3(0.0);
            for (uint g = 0u; g < gl_NumSubgroups; g++) t += sums[g];
            uint o = (group * pc.coeffs + k) * 3u;
            rows_out[o] = t.x;
            rows_out[o + 1u] = t.y;
            rows_out[o + 2u] = t.z;
        }
        barrier();
#else
        tree[tid] = v;
        barrier();
        for (uint stride = SH_WORKGROUP / 2u; stride > 0u; stride /= 2u) {
            if (tid < stride) tree[tid] += tree[tid + stride];
            barrier();
        }
        if (tid == 0u) {
            uint o = (group * pc.coeffs + k) * 3u;
            rows_out[o] = tree[0].x;
            rows_out[o + 1u] = tree[0].y;
            rows_out[o + 2u] = tree[0].z;
        }
        barrier();
#endif
    }
}
