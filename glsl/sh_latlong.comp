#version 460
// SH projection of a lat-long map, second step: the sum over rows. In the frame P whose pole
// is the map's (θ from the file's +Y, φ = 2πu; P·f = (−f.z, f.x, f.y)) the basis at a node is
// N_lm·P_l^|m|(cos θ)·T_m(φ), so row j adds, for each (l, m),
//     S_j · 2cos(|m|δ) · Σ_b ρ_b N_lm P_l^|m|(cos θ_b) · F_j(m)
// with F_j(m) the row's Fourier sums (sh_rows.comp), θ_b = π(j + ½ ∓ g)/H its Gauss nodes in θ,
// ρ_b = 2π² sin θ_b the density, ±δ = ±2πg/W the nodes' offsets in φ (Σ_a T_m(φ_c ± δ) =
// 2cos(|m|δ)·T_m(φ_c)), and S_j = Ω_j / Σ_nodes ρ (the rule scaled to the texel's exact solid
// angle): exactly the per-texel rule of sh_project.comp and math::sh::project. One invocation a
// row; the workgroup sums its rows, and its sums turn from frame P to the world's,
// c = M(Qᵀ)·c' with Q = P·(file → world)ᵀ (an improper Q = −R flips the odd bands first), before
// the tree of sh_reduce.comp adds the workgroups.
#extension GL_GOOGLE_include_directive : require
#ifdef USE_SUBGROUPS
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_basic : require
#endif
#include "generated.glsl"

layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;
layout(constant_id = 1) const uint LMAX = 2u;
const uint NC = (LMAX + 1u) * (LMAX + 1u);
const uint NM = 2u * LMAX + 1u;

#define SH_SPEC_BASIS
#include "mappings.glsl"
#include "sh.glsl"
// The Ivanic–Ruedenberg rotation only: zxzxz's fixed blocks are never read.
#define SH_X90(i) 0.0
#include "sh_rotate.glsl"

layout(std430, set = 0, binding = BINDING_SH_LATLONG_ROWS) readonly buffer Rows { float rows[]; };
layout(std430, set = 0, binding = BINDING_SH_LATLONG_PARTIALS) writeonly buffer Partials { float partials[]; };

// The push block, generated from src/abi/push.rs.
PUSH_ShLatLongPush

#ifdef USE_SUBGROUPS
shared vec3 sums[SH_WORKGROUP];
#else
shared vec3 tree[SH_WORKGROUP];
#endif
shared vec3 totals[NC];

void main() {
    uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    uint tid = gl_LocalInvocationID.x;
    uint row = group * SH_WORKGROUP + tid;
    vec3 acc[NC];
    for (uint k = 0u; k < NC; k++) acc[k] = vec3(0.0);
    if (row < pc.size.y) {
        float h = float(pc.size.y);
        float t0 = PI * (float(row) + 0.5 - GAUSS2_OFFSET) / h;
        float t1 = PI * (float(row) + 0.5 + GAUSS2_OFFSET) / h;
        float w0 = 2.0 * PI * PI * sin(t0), w1 = 2.0 * PI * PI * sin(t1);
        // Σ_nodes ρ = 2(ρ₀ + ρ₁): two nodes in φ at each θ.
        float s = texel_solid_angle(MAPPING_LATLONG, pc.size, ivec2(0, int(row))) / (2.0 * (w0 + w1));
        float delta = TAU * GAUSS2_OFFSET / float(pc.size.x);
        float y0[NC], y1[NC];
        sh_basis_spec(vec3(sin(t0), 0.0, cos(t0)));
        for (uint k = 0u; k < NC; k++) y0[k] = sh_y[k];
        sh_basis_spec(vec3(sin(t1), 0.0, cos(t1)));
        for (uint k = 0u; k < NC; k++) y1[k] = sh_y[k];
        for (uint l = 0u; l <= LMAX; l++) {
            for (int m = -int(l); m <= int(l); m++) {
                uint am = uint(abs(m));
                // The basis at φ = 0 holds N·P at (l, |m|) for either sign of m.
                uint ka = l * (l + 1u) + am;
                float p = w0 * y0[ka] + w1 * y1[ka];
                uint o = (row * NM + uint(int(LMAX) + m)) * 3u;
                vec3 f = vec3(rows[o], rows[o + 1u], rows[o + 2u]);
                acc[uint(int(l * (l + 1u)) + m)] = (s * 2.0 * cos(float(am) * delta) * p) * f;
            }
        }
    }
    for (uint k = 0u; k < NC; k++) {
#ifdef USE_SUBGROUPS
        vec3 v = subgroupAdd(acc[k]);
        if (subgroupElect()) sums[gl_SubgroupID] = v;
        barrier();
        if (tid == 0u) {
            vec3 t = vec3(0.0);
            for (uint g = 0u; g < gl_NumSubgroups; g++) t += sums[g];
            totals[k] = t;
        }
        barrier();
#else
        tree[tid] = acc[k];
        barrier();
        for (uint stride = SH_WORKGROUP / 2u; stride > 0u; stride /= 2u) {
            if (tid < stride) tree[tid] += tree[tid + stride];
            barrier();
        }
        if (tid == 0u) totals[k] = tree[0];
        barrier();
#endif
    }
    if (tid < 3u) {
        // Channel tid of the workgroup's sums, turned into the world frame.
        mat3 r;
        for (uint i = 0u; i < 3u; i++)
            for (uint j = 0u; j < 3u; j++) r[j][i] = pc.rotation[i][j];
        float c[SH_MAX_COEFFS];
        for (uint k = 0u; k < SH_MAX_COEFFS; k++) {
            float v = k < NC ? totals[k][tid] : 0.0;
            uint l = uint(floor(sqrt(float(k)) + 1e-3));
            c[k] = pc.parity != 0u && (l & 1u) == 1u ? -v : v;
        }
        sh_rotate_ivanic(r, LMAX, c);
        for (uint k = 0u; k < NC; k++) partials[(group * NC + k) * 3u + tid] = c[k];
    }
}
