#version 460
// SH projection, first level: each invocation takes one texel, computes L·∫Y_k dω over the
// texel for every coefficient, and the workgroup sums them (subgroup adds, or a shared-memory tree without
// subgroups) into one partial sum per coefficient. sh_reduce.comp then sums the partials
// pairwise in a tree: no sum in f32 is ever longer than a workgroup, so a sun 1e5 times the
// sky keeps the error at O(eps·log N).
#extension GL_GOOGLE_include_directive : require
#ifdef USE_SUBGROUPS
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_basic : require
#endif
#include "mappings.glsl"
#include "sh.glsl"

layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;

layout(set = 0, binding = BINDING_SH_SRC) uniform sampler2DArray src;
layout(std430, set = 0, binding = BINDING_SH_PARTIALS) writeonly buffer Partials { float partials[]; };

// The push block, generated from src/abi.rs.
PUSH_ShProjectPush

vec3 to_world(vec3 f) {
    return vec3(dot(pc.file_to_world[0].xyz, f), dot(pc.file_to_world[1].xyz, f), dot(pc.file_to_world[2].xyz, f));
}

// ∫ Y_k over a texel the rim of an angular or paraboloid disc cuts: the clipped Gauss-Legendre
// rule of clipped_square (mappings.glsl), evaluating the basis at every node. Only rim texels
// take this path; it makes the sums over texels exact to the rule's precision instead of
// leaving a first-order error where the disc cuts a texel.
void sh_clipped(uint m, uint layer, vec2 lo, vec2 hi, uint lmax, uint n,
                inout float acc[SH_MAX_COEFFS], inout float wsum) {
    float y[SH_MAX_COEFFS];
    float xs[6];
    int cnt = clipped_breaks(lo, hi, xs);
    for (int p = 0; p + 1 < cnt; p++) {
        int parts = int(ceil((xs[p + 1] - xs[p]) * 4.0));
        float hx = 0.5 * (xs[p + 1] - xs[p]) / float(max(parts, 1));
        for (int q = 0; q < parts; q++) {
            float x0 = xs[p] + 2.0 * hx * float(q);
            for (int a = 0; a < 8; a++) {
                float u = 0.5 + 0.5 * (a < 4 ? -1.0 : 1.0) * GL8_X[a & 3];
                float x = x0 + 2.0 * hx * u * u * (3.0 - 2.0 * u);
                float jac = 6.0 * u * (1.0 - u);
                if (abs(x) >= 1.0) continue;
                float e = sqrt((1.0 - x) * (1.0 + x));
                float ya = max(lo.y, -e), yb = min(hi.y, e);
                if (yb <= ya) continue;
                float my = 0.5 * (ya + yb), hy = 0.5 * (yb - ya);
                for (int b = 0; b < 8; b++) {
                    vec2 pt = vec2(x, my + hy * (b < 4 ? -1.0 : 1.0) * GL8_X[b & 3]);
                    float w = GL8_W[a & 3] * GL8_W[b & 3] * hx * hy * jac * square_density(m, pt);
                    Coord c;
                    c.layer = layer;
                    c.uv = 0.5 * (pt + 1.0);
                    sh_basis(lmax, to_world(coord_to_dir(m, c)), y);
                    for (uint k = 0u; k < n; k++) acc[k] += w * y[k];
                    wsum += w;
                }
            }
        }
    }
}

#ifdef USE_SUBGROUPS
shared vec3 sums[SH_WORKGROUP];  // one slot per subgroup (at most SH_WORKGROUP of them)
#else
shared vec3 tree[SH_WORKGROUP];
#endif

void main() {
    // Large maps need more groups than one dispatch dimension allows: the grid is 2D.
    uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    uint tid = gl_LocalInvocationID.x;
    uint i = group * SH_WORKGROUP + tid;
    uint n = (pc.lmax + 1u) * (pc.lmax + 1u);
    float y[SH_MAX_COEFFS];
    float acc[SH_MAX_COEFFS];
    for (uint k = 0u; k < n; k++) acc[k] = 0.0;
    vec3 l = vec3(0.0);
    if (i < pc.texels) {
        uint per_layer = pc.size.x * pc.size.y;
        uint layer = i / per_layer, r = i % per_layer;
        ivec2 p = ivec2(r % pc.size.x, r / pc.size.x);
        ivec2 source = integration_source(pc.mapping, pc.size, p);
        if (source.x >= 0) {
            // ∫ Y_k over the texel by 2x2 Gauss points weighted by the density (fourth order);
            // texels the rim of a disc cuts take the clipped rule instead.
            float wsum = 0.0;
            vec2 lo = 2.0 * vec2(p) / vec2(pc.size) - 1.0;
            vec2 hi = 2.0 * vec2(p + 1) / vec2(pc.size) - 1.0;
            vec2 far_ = max(abs(lo), abs(hi));
            bool cut = (pc.mapping == MAPPING_ANGULAR || pc.mapping == MAPPING_DUAL_PARABOLOID)
                && dot(far_, far_) > 1.0;
            if (cut) {
                sh_clipped(pc.mapping, layer, lo, hi, pc.lmax, n, acc, wsum);
            } else {
                for (uint q = 0u; q < 4u; q++) {
                    vec2 off = vec2((q & 1u) == 0u ? -GAUSS2_OFFSET : GAUSS2_OFFSET, q < 2u ? -GAUSS2_OFFSET : GAUSS2_OFFSET);
                    Coord c;
                    c.layer = layer;
                    c.uv = (vec2(p) + 0.5 + off) / vec2(pc.size);
                    float w = density(pc.mapping, c.uv);
                    sh_basis(pc.lmax, to_world(coord_to_dir(pc.mapping, c)), y);
                    for (uint k = 0u; k < n; k++) acc[k] += w * y[k];
                    wsum += w;
                }
            }
            if (wsum <= 0.0) {
                // A sliver too thin for any node: its centre stands for it.
                Coord c;
                c.layer = layer;
                c.uv = (vec2(p) + 0.5) / vec2(pc.size);
                sh_basis(pc.lmax, to_world(coord_to_dir(pc.mapping, c)), y);
                for (uint k = 0u; k < n; k++) acc[k] = y[k];
                wsum = 1.0;
            }
            float omega = texel_solid_angle(pc.mapping, pc.size, p);
            l = texelFetch(src, ivec3(source, int(layer)), 0).rgb * (omega / wsum);
        }
    }
    for (uint k = 0u; k < n; k++) {
        vec3 v = l * acc[k];
#ifdef USE_SUBGROUPS
        vec3 s = subgroupAdd(v);
        if (subgroupElect()) sums[gl_SubgroupID] = s;
        barrier();
        if (tid == 0u) {
            vec3 t = vec3(0.0);
            for (uint g = 0u; g < gl_NumSubgroups; g++) t += sums[g];
            uint o = (group * n + k) * 3u;
            partials[o] = t.x;
            partials[o + 1u] = t.y;
            partials[o + 2u] = t.z;
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
            uint o = (group * n + k) * 3u;
            partials[o] = tree[0].x;
            partials[o + 1u] = tree[0].y;
            partials[o + 2u] = tree[0].z;
        }
        barrier();
#endif
    }
}
