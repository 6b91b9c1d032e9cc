#version 460
// SH projection of a lat-long map, first step: per row j, the Fourier sums of its texels
// F_j(m) = Σ_i L(i, j)·T_m(φ_i) for m = −LMAX … LMAX, with T_m = cos(mφ) for m ≥ 0 and
// sin(|m|φ) for m < 0, φ_i = 2π(i + ½)/W the column's centre (cos and sin of mφ by the
// angle-addition recurrence). A lat-long texel's 2 × 2 Gauss rule is a product of a rule in φ
// and one in θ, and the basis (in the frame whose pole is the map's) a product of a function
// of θ and T_m(φ): the projection separates into these sums and a sum over rows
// (sh_latlong.comp), 2·LMAX + 1 multiply-adds a texel and channel instead of the basis at
// four nodes. One workgroup a row; its invocations stride over the columns and the workgroup
// sums them (subgroup adds, the workgroup one subgroup wide where the device has them; or a
// shared-memory tree).
#extension GL_GOOGLE_include_directive : require
#ifdef USE_SUBGROUPS
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_basic : require
#endif
#include "generated.glsl"
#include "mappings.glsl"

layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;
// The band: the sums' array is sized for it, its loops unroll and stay in registers.
layout(constant_id = 1) const uint LMAX = 2u;
const uint NM = 2u * LMAX + 1u;

layout(set = 0, binding = BINDING_SH_ROWS_SRC) uniform sampler2DArray src;
layout(std430, set = 0, binding = BINDING_SH_ROWS_OUT) writeonly buffer Rows { float rows[]; };

// The push block, generated from src/abi/push.rs.
PUSH_ShLatLongPush

#ifdef USE_SUBGROUPS
shared vec3 sums[SH_WORKGROUP];
#else
shared vec3 tree[SH_WORKGROUP];
#endif

void main() {
    // Tall maps need more rows than one dispatch dimension allows: the grid is 2D.
    uint row = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    if (row >= pc.size.y) return;  // the whole workgroup: no barrier is skipped by some
    uint tid = gl_LocalInvocationID.x;
    vec3 f[NM];
    for (uint k = 0u; k < NM; k++) f[k] = vec3(0.0);
    float step = 6.28318530717958647692 / float(pc.size.x);
    for (uint i = tid; i < pc.size.x; i += gl_WorkGroupSize.x) {
        vec3 l = finite_or_zero(texelFetch(src, ivec3(int(i), int(row), 0), 0).rgb);
        float phi = step * (float(i) + 0.5);
        float c1 = cos(phi), s1 = sin(phi);
        f[LMAX] += l;
        float cm = 1.0, sm = 0.0;
        for (uint m = 1u; m <= LMAX; m++) {
            float c = cm * c1 - sm * s1;
            sm = sm * c1 + cm * s1;
            cm = c;
            f[LMAX + m] += l * cm;
            f[LMAX - m] += l * sm;
        }
    }
    for (uint k = 0u; k < NM; k++) {
#ifdef USE_SUBGROUPS
        vec3 s = subgroupAdd(f[k]);
        if (subgroupElect()) sums[gl_SubgroupID] = s;
        barrier();
        if (tid == 0u) {
            vec3 t = vec3(0.0);
            for (uint g = 0u; g < gl_NumSubgroups; g++) t += sums[g];
            uint o = (row * NM + k) * 3u;
            rows[o] = t.x;
            rows[o + 1u] = t.y;
            rows[o + 2u] = t.z;
        }
        barrier();
#else
        tree[tid] = f[k];
        barrier();
        for (uint stride = gl_WorkGroupSize.x / 2u; stride > 0u; stride /= 2u) {
            if (tid < stride) tree[tid] += tree[tid + stride];
            barrier();
        }
        if (tid == 0u) {
            uint o = (row * NM + k) * 3u;
            rows[o] = tree[0].x;
            rows[o + 1u] = tree[0].y;
            rows[o + 2u] = tree[0].z;
        }
        barrier();
#endif
    }
}
