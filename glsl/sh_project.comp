#version 460
// SH projection of angular, cube and paraboloid maps (lat-long maps separate: sh_rows.comp
// and sh_latlong.comp), first level: each invocation walks RUN texels (strided by the workgroup,
// so neighbouring lanes read neighbouring texels), adds L·∫Y_k dω over each texel in
// registers, and the workgroup then sums its invocations (subgroup adds, or a shared-memory
// tree without subgroups) into one partial sum per coefficient. sh_reduce.comp sums the
// partials pairwise in a tree: no f32 sum is longer than RUN plus a workgroup, so a sun
// 1e5 times the sky keeps the error at O(eps·(RUN + log N)).
#extension GL_GOOGLE_include_directive : require
#ifdef USE_SUBGROUPS
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_basic : require
#endif

#include "generated.glsl"

layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;
// The band is a specialisation constant: the arrays are sized for it and the basis loops
// unroll, so llvmpipe keeps the sums in registers instead of spilling an 81-float array.
layout(constant_id = 1) const uint LMAX = 2u;
// The mapping too: the other mappings' branches (and the rim rule on cube maps) vanish, which
// shortens both the run and llvmpipe's JIT of the shader.
layout(constant_id = 2) const uint MAPPING = 0u;
const uint NC = (LMAX + 1u) * (LMAX + 1u);
// Texels per invocation: SH_RUN, or 1 on disc mappings. llvmpipe cuts a loop after 65535
// iterations per invocation, counted across re-entries, and one rim texel's clipped rule at
// l = 8 takes 26k of them.
layout(constant_id = 3) const uint RUN = 1u;

#define SH_SPEC_BASIS
#include "mappings.glsl"
#include "sh.glsl"

layout(set = 0, binding = BINDING_SH_SRC) uniform sampler2DArray src;
layout(std430, set = 0, binding = BINDING_SH_PARTIALS) writeonly buffer Partials { float partials[]; };

// The push block, generated from src/abi/push.rs.
PUSH_ShProjectPush

vec3 to_world(vec3 f) {
    return vec3(dot(pc.file_to_world[0].xyz, f), dot(pc.file_to_world[1].xyz, f), dot(pc.file_to_world[2].xyz, f));
}


#ifndef GRID_ONLY
// ∫ Y_k over a texel the rim of an angular or paraboloid disc cuts: the clipped Gauss-Legendre
// rule of clipped_square (mappings.glsl), evaluating the basis at every node. Only rim texels
// take this path; it makes the sums over texels exact to the rule's precision instead of
// leaving a first-order error where the disc cuts a texel. Returns Σw; with add, also adds
// l·w·Y_k at every node to acc (called twice, so that no per-texel array of NC floats is
// needed).
float sh_clipped(uint m, uint layer, vec2 lo, vec2 hi, bool add, vec3 l, inout vec3 acc[NC]) {
    float wsum = 0.0;
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
                    if (add) {
                        // The run-time-band basis: with sh_basis_spec here llvmpipe
                        // miscompiled this loop nest above l = 4.
                        float y[SH_MAX_COEFFS];
                        sh_basis(LMAX, to_world(coord_to_dir(m, c)), y);
                        for (uint k = 0u; k < NC; k++) acc[k] += (l * w) * y[k];
                    }
                    wsum += w;
                }
            }
        }
    }
    return wsum;
}
#endif

#ifdef USE_SUBGROUPS
shared vec3 sums[SH_WORKGROUP];  // one slot per subgroup (at most SH_WORKGROUP of them)
#else
shared vec3 tree[SH_WORKGROUP];
#endif

// Adds texel i's L·ω·∫Y_k/Σw to acc. Regular texels take 2x2 Gauss points weighted by the
// density (fourth order) and add each node's basis straight into acc, so no per-texel array
// of NC floats competes for registers; texels the rim of a disc cuts take the clipped rule.
void add_texel(uint i, inout vec3 acc[NC]) {
    uvec2 lr = div_rem(i, pc.size.x * pc.size.y);
    uint layer = lr.x;
    uvec2 yx = div_rem(lr.y, pc.size.x);
    ivec2 p = ivec2(yx.y, yx.x);
    ivec2 source = integration_source(MAPPING, pc.size, p);
    if (source.x < 0) return;
    float omega = texel_solid_angle(MAPPING, pc.size, p);
    vec3 radiance = finite_or_zero(texelFetch(src, ivec3(source, int(layer)), 0).rgb);
    vec2 lo = 2.0 * vec2(p) / vec2(pc.size) - 1.0;
    vec2 hi = 2.0 * vec2(p + 1) / vec2(pc.size) - 1.0;
    vec2 far_ = max(abs(lo), abs(hi));
#ifndef GRID_ONLY
    // (Built with GRID_ONLY for cube maps, which have no rim: a smaller module.)
    if ((MAPPING == MAPPING_ANGULAR || MAPPING == MAPPING_DUAL_PARABOLOID) && dot(far_, far_) > 1.0) {
        float wsum = sh_clipped(MAPPING, layer, lo, hi, false, vec3(0.0), acc);
        if (wsum > 0.0) {
            sh_clipped(MAPPING, layer, lo, hi, true, radiance * (omega / wsum), acc);
            return;
        }
    }
#endif
    vec3 dirs[4];
    float w[4];
    for (uint q = 0u; q < 4u; q++) {
        vec2 off = vec2((q & 1u) == 0u ? -GAUSS2_OFFSET : GAUSS2_OFFSET, q < 2u ? -GAUSS2_OFFSET : GAUSS2_OFFSET);
        Coord c;
        c.layer = layer;
        c.uv = (vec2(p) + 0.5 + off) / vec2(pc.size);
        w[q] = density(MAPPING, c.uv);
        dirs[q] = coord_to_dir(MAPPING, c);
    }
    float wsum = w[0] + w[1] + w[2] + w[3];
    if (wsum <= 0.0) {
        // A sliver too thin for any node: its centre stands for it.
        Coord c;
        c.layer = layer;
        c.uv = (vec2(p) + 0.5) / vec2(pc.size);
        sh_basis_spec(to_world(coord_to_dir(MAPPING, c)));
        for (uint k = 0u; k < NC; k++) acc[k] += radiance * omega * sh_y[k];
        return;
    }
    vec3 l = radiance * (omega / wsum);
    for (uint q = 0u; q < 4u; q++) {
        sh_basis_spec(to_world(dirs[q]));
        vec3 lw = l * w[q];
        for (uint k = 0u; k < NC; k++) acc[k] += lw * sh_y[k];
    }
}

void main() {
    // Large maps need more groups than one dispatch dimension allows: the grid is 2D.
    uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    uint tid = gl_LocalInvocationID.x;
    vec3 acc[NC];
    for (uint k = 0u; k < NC; k++) acc[k] = vec3(0.0);
    uint base = group * SH_WORKGROUP * RUN + tid;
    for (uint j = 0u; j < RUN; j++) {
        uint i = base + j * SH_WORKGROUP;
        if (i < pc.texels) add_texel(i, acc);
    }
    for (uint k = 0u; k < NC; k++) {
        vec3 v = acc[k];
#ifdef USE_SUBGROUPS
        vec3 s = subgroupAdd(v);
        if (subgroupElect()) sums[gl_SubgroupID] = s;
        barrier();
        if (tid == 0u) {
            vec3 t = vec3(0.0);
            for (uint g = 0u; g < gl_NumSubgroups; g++) t += sums[g];
            uint o = (group * NC + k) * 3u;
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
            uint o = (group * NC + k) * 3u;
            partials[o] = tree[0].x;
            partials[o + 1u] = tree[0].y;
            partials[o + 2u] = tree[0].z;
        }
        barrier();
#endif
    }
}
