#version 460
// Light texels (src/math/lights.rs) added to one level of a cube: at each texel centre r,
// (1/∫K)·Σ_t L_t·∫_t K(r·ω) dω over the light texels t, summed through the texels' tree
// (math::light_tree::LightTree::sum: a node wholly behind the plane normal to r skipped, one
// small against the kernel's scale there, or whose bound error is within pc.budget of the
// level's luminance before the lights, taken whole by its four sigma points; leaves' texels
// one by one). Each texel's integral by one node at its centre where it is small next to the
// kernel's scale there (light_centre_only: α at the peak, a fraction of the chord in GGX's
// θ⁻⁴ tail, a radian for the cosine), else by its quadrature nodes: where the buffer keeps
// coarser quadratures (pc.coarse_at), those of ⌈PER_WIDTH·ρ/w⌉ cells where that is fewer
// than its own (4 nodes in GGX's tail). The kernel is the clamped cosine (irradiance) or
// split-sum's GGX at n = v = r. Float64 twin: math::light_tree::LightTree::sum.
// LIGHTS_KERNEL_CLUSTERS adds light clusters' irradiance instead
// (math::lights::cluster_irradiance).
#extension GL_GOOGLE_include_directive : require
#include "mappings.glsl"
#include "lights.glsl"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
// Built twice: with TEXEL_VIEW the list is read through its rgba32f texel view (llvmpipe loads
// a storage buffer lane by lane, a texel view as one gather), else as a storage buffer (for
// lists longer than the device's maxTexelBufferElements).
#ifdef TEXEL_VIEW
layout(set = 0, binding = BINDING_LIGHTS_TEXELS) uniform samplerBuffer lt_view;
#define LT(i) texelFetch(lt_view, int(i))
#else
layout(std430, set = 0, binding = BINDING_LIGHTS_TEXELS) readonly buffer Texels { vec4 lt[]; };
#define LT(i) lt[i]
#endif
layout(set = 0, binding = BINDING_LIGHTS_DST, rgba32f) uniform image2DArray dst;

// The push block, generated from src/abi/push.rs.
PUSH_LightsPush

float kern(float a2, vec3 r, vec3 w) {
    vec3 e = r - w;
    float g = 0.5 * dot(e, e);
    if (pc.kernel == LIGHTS_KERNEL_COSINE) return max(1.0 - g, 0.0);
    return chain_kernel(a2, g);
}

// Where texel t's quadrature for a kernel of squared scale w2 starts among the list's vec4s,
// and its node count (math::lights::local_nodes).
uvec2 texel_nodes(uint t, float rho, float w2) {
    uint first = t * (LIGHT_HEADER_VEC4S + pc.nodes) + LIGHT_HEADER_VEC4S, count = pc.nodes;
    if (pc.coarse_at != 0u) {
        uint c = uint(clamp(ceil(LIGHT_PER_WIDTH * rho / sqrt(w2)), 1.0, 8.0));
        if (c < pc.cells) {
            first = pc.coarse_at + t * coarse_offset(pc.cells) + coarse_offset(c);
            count = 4u * c * c;
        }
    }
    return uvec2(first, count);
}

// The light texels through their tree (math::light_tree::LightTree::sum), a node allowed an
// error `allowance` in the sum's units. One item a step, each at most LIGHT_STEP_NODES (4)
// kernel values (a node's sigma points, a texel's centre, or that many of its quadrature
// nodes), since llvmpipe runs every branch of a step for its lanes' different items: i is
// the next node, j..end the current leaf's texels, and c which step of texel j's nodes comes
// next. The bound counts every node and every texel's nodes in steps (quadratures of
// (2·cells)² nodes, a multiple of the step).
vec3 tree_sum(vec3 r, float a, float a2, float allowance) {
    vec3 sum = vec3(0.0);
    uint stride = LIGHT_HEADER_VEC4S + pc.nodes;
    uint i = 0u, j = 0u, end = 0u, c = 0u;
    uint bound = pc.tree_nodes + pc.count * max(pc.nodes / LIGHT_STEP_NODES, 1u);
    for (uint step = 0u; step < bound; step++) {
        if (j >= end && i >= pc.tree_nodes) break;
        mat4x3 d = mat4x3(0.0);
        vec4 w = vec4(0.0);
        vec3 light = vec3(0.0);
        if (j < end) {
            vec4 centre = LT(j * stride);
            vec4 l = LT(j * stride + 1u);
            light = l.rgb;
            float w2 = light_scale2(a, r - centre.xyz);
            if (light_centre_only(l.w, w2, stride)) {
                d[0] = centre.xyz;
                w.x = centre.w;
                j++;
            } else {
                uvec2 q = texel_nodes(j, l.w, w2);
                uint at = q.x + LIGHT_STEP_NODES * c;
                vec4 q0 = LT(at), q1 = LT(at + 1u), q2 = LT(at + 2u), q3 = LT(at + 3u);
                d = mat4x3(q0.xyz, q1.xyz, q2.xyz, q3.xyz);
                w = vec4(q0.w, q1.w, q2.w, q3.w);
                c++;
                if (LIGHT_STEP_NODES * c >= q.y) {
                    c = 0u;
                    j++;
                }
            }
        } else {
            // (centre, reach), (power, ρ), (axis 0, luminance), (axis 1, 0), (first, count, skip).
            uint at = pc.tree_at + i * LIGHT_TREE_VEC4S;
            vec4 n0 = LT(at), n1 = LT(at + 1u), n2 = LT(at + 2u), n3 = LT(at + 3u);
            uvec4 range = uvec4(LT(at + 4u));
            if (dot(r, n0.xyz) + n0.w <= 0.0) {
                // Wholly behind the plane normal to r, where the kernel vanishes
                // (math::light_tree::behind).
                i = range.z;
            } else if (light_tree_whole(n0, n2.w, r, a, r, allowance, LIGHT_KERNEL_FADE)) {
                d = mat4x3(normalize(n0.xyz + n2.xyz), normalize(n0.xyz - n2.xyz),
                           normalize(n0.xyz + n3.xyz), normalize(n0.xyz - n3.xyz));
                w = vec4(0.25);
                light = n1.rgb;
                i = range.z;
            } else if (range.y <= LIGHT_LEAF_TEXELS) {
                j = range.x;
                end = range.x + range.y;
                i = range.z;
            } else {
                i++;
            }
        }
        float k = w.x * kern(a2, r, d[0]) + w.y * kern(a2, r, d[1]) + w.z * kern(a2, r, d[2])
            + w.w * kern(a2, r, d[3]);
        sum += k * light;
    }
    return sum;
}

void main() {
    uvec3 id = gl_GlobalInvocationID + uvec3(0u, 0u, pc.layer);
    if (any(greaterThanEqual(id.xy, uvec2(pc.size)))) return;
    Coord c;
    c.layer = id.z;
    c.uv = (vec2(id.xy) + 0.5) / float(pc.size);
    vec3 r = coord_to_dir(MAPPING_CUBE, c);
    if (pc.kernel == LIGHTS_KERNEL_CLUSTERS) {
        // Light clusters (math::lights::cluster_irradiance): max(0, r·V) per channel.
        vec3 e = vec3(0.0);
        for (uint k = 0u; k < pc.count; k++) {
            uint at = pc.at + k * LIGHT_CLUSTER_VEC4S;
            e += max(vec3(dot(r, LT(at).xyz), dot(r, LT(at + 1u).xyz), dot(r, LT(at + 2u).xyz)), vec3(0.0));
        }
        vec4 prev = imageLoad(dst, ivec3(id));
        imageStore(dst, ivec3(id), vec4(prev.rgb + e, prev.a));
        return;
    }
    float a = pc.kernel == LIGHTS_KERNEL_COSINE ? 1.0 : max(pc.alpha, GGX_ALPHA_MIN);
    float a2 = a * a;
    vec4 prev = imageLoad(dst, ivec3(id));
    vec3 sum = tree_sum(r, a, a2, pc.budget * dot(LUMINANCE, prev.rgb));
    imageStore(dst, ivec3(id), vec4(prev.rgb + sum * pc.inv_norm, prev.a));
}
