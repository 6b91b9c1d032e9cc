#version 460
// The GPU extraction's light records (passes::extract) added to one level of a cube, filtered
// by a kernel: at each texel centre r, inv_norm · Σ_t L_t·∫_t K(r·ω) dω over the kept records
// (their count from the extraction's header, so nothing is read back), each integral by t's
// centre where t is small next to the kernel's scale there (light_centre_only), else by
// (2·cells)² Gauss nodes over t weighted by the mapping's footprint and scaled to t's ω, cells
// ⌈PER_WIDTH·ρ/w⌉ (1 to 8) from t's own size ρ and the kernel's scale w at t: PER_WIDTH nodes
// across the local width, 4 nodes far in the tail. The kernel is the clamped cosine
// (irradiance) or split-sum's GGX at n = v = r. Float64 twin: math::lights::light_sum_local.
#extension GL_GOOGLE_include_directive : require
#include "mappings.glsl"
#include "lights.glsl"
#include "extract.glsl"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = BINDING_EXTRACT_ADD_STATE) readonly buffer State { uint state[]; };
layout(std430, set = 0, binding = BINDING_EXTRACT_ADD_LIGHTS) readonly buffer Lights { Record records[]; };
layout(set = 0, binding = BINDING_EXTRACT_ADD_DST, rgba32f) uniform image2DArray dst;

// The push block, generated from src/abi/push.rs.
PUSH_ExtractAddPush

vec3 to_world(vec3 d) {
    return vec3(dot(pc.file_to_world[0].xyz, d), dot(pc.file_to_world[1].xyz, d),
                dot(pc.file_to_world[2].xyz, d));
}

float kern(float a2, vec3 r, vec3 w) {
    vec3 e = r - w;
    float g = 0.5 * dot(e, e);
    if (pc.kernel == LIGHTS_KERNEL_COSINE) return max(1.0 - g, 0.0);
    return chain_kernel(a2, g);
}

// ∫_t K dω by (2·cells)² nodes over texel t (math::lights::nodes).
float by_nodes(Record t, uint cells, float a2, vec3 r) {
    uint side = 2u * cells;
    float sum = 0.0, total = 0.0;
    for (uint b = 0u; b < side; b++) {
        for (uint a = 0u; a < side; a++) {
            vec2 at = vec2(float(a / 2u), float(b / 2u)) + 0.5
                    + vec2((a & 1u) == 0u ? -GAUSS2_OFFSET : GAUSS2_OFFSET,
                           (b & 1u) == 0u ? -GAUSS2_OFFSET : GAUSS2_OFFSET);
            vec2 uv = (vec2(t.texel.yz) + at / float(cells)) / vec2(pc.map_size);
            float w = footprint_weight(pc.mapping, uv);
            sum += kern(a2, r, to_world(coord_to_dir(pc.mapping, Coord(t.texel.x, uv)))) * w;
            total += w;
        }
    }
    // A texel whose nodes all weigh nothing takes its centre (math::lights::nodes).
    return total > 0.0 ? sum * t.dir_omega.w / total : kern(a2, r, to_world(t.dir_omega.xyz)) * t.dir_omega.w;
}

void main() {
    uvec3 id = gl_GlobalInvocationID + uvec3(0u, 0u, pc.layer);
    if (any(greaterThanEqual(id.xy, uvec2(pc.size)))) return;
    vec3 r = coord_to_dir(MAPPING_CUBE, Coord(id.z, (vec2(id.xy) + 0.5) / float(pc.size)));
    float a = max(pc.alpha, GGX_ALPHA_MIN);
    float a2 = a * a;
    float scale = pc.kernel == LIGHTS_KERNEL_COSINE ? 1.0 : a;
    uint count = state[EXTRACT_WORD_KEPT];
    vec3 sum = vec3(0.0);
    for (uint k = 0u; k < count; k++) {
        Record t = records[k];
        vec3 c = to_world(t.dir_omega.xyz);
        float w2 = light_scale2(scale, r - c);
        float rho = sqrt(t.dir_omega.w);
        uint cells = uint(clamp(ceil(LIGHT_PER_WIDTH * rho / sqrt(w2)), 1.0, 8.0));
        float integral = light_centre_only(rho, w2, LIGHT_HEADER_VEC4S + 1u)
            ? kern(a2, r, c) * t.dir_omega.w
            : by_nodes(t, cells, a2, r);
        sum += integral * t.excess_y.rgb;
    }
    vec4 prev = imageLoad(dst, ivec3(id));
    imageStore(dst, ivec3(id), vec4(prev.rgb + sum * pc.inv_norm, prev.a));
}
