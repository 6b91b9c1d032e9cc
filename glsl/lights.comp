#version 460
// Light texels (src/math/lights.rs) added exactly to one level of a cube: at each texel
// centre r, (1/∫K)·Σ_t L_t·∫_t K(r·ω) dω over the light texels t, each integral by one node
// at t's centre where t is small next to the kernel's scale there (light_centre_only: α at
// the peak, a fraction of the chord in GGX's θ⁻⁴ tail, a radian for the cosine), else by t's
// quadrature nodes: where the buffer keeps coarser quadratures (pc.coarse_at), those of
// ⌈PER_WIDTH·ρ/w⌉ cells where that is fewer than t's own (4 nodes in GGX's tail). The kernel is the clamped cosine (irradiance) or split-sum's GGX at
// n = v = r. Float64 twin: math::lights::light_sum. LIGHTS_KERNEL_CLUSTERS adds light clusters'
// irradiance instead (math::lights::cluster_irradiance).
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

// Where the quadrature of c cells starts among a texel's coarser ones: Σ (2k)², k < c
// (math::lights::coarse_offset).
uint coarse_offset(uint c) {
    return 2u * (c - 1u) * c * (2u * c - 1u) / 3u;
}

float kern(float a2, vec3 r, vec3 w) {
    vec3 e = r - w;
    float g = 0.5 * dot(e, e);
    if (pc.kernel == LIGHTS_KERNEL_COSINE) return max(1.0 - g, 0.0);
    return chain_kernel(a2, g);
}

void main() {
    uvec3 id = gl_GlobalInvocationID;
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
    float a = max(pc.alpha, GGX_ALPHA_MIN);
    float a2 = a * a;
    uint stride = LIGHT_HEADER_VEC4S + pc.nodes;
    vec3 sum = vec3(0.0);
    for (uint t = 0u; t < pc.count; t++) {
        vec4 centre = LT(t * stride);
        vec4 light = LT(t * stride + 1u);
        vec3 e = r - centre.xyz;
        float w2 = light_scale2(pc.kernel == LIGHTS_KERNEL_COSINE ? 1.0 : a, e);
        float k = 0.0;
        if (light_centre_only(light.w, w2, stride)) {
            k = kern(a2, r, centre.xyz) * centre.w;
        } else {
            // math::lights::local_nodes
            uint first = t * stride + LIGHT_HEADER_VEC4S, count = pc.nodes;
            if (pc.coarse_at != 0u) {
                uint c = uint(clamp(ceil(LIGHT_PER_WIDTH * light.w / sqrt(w2)), 1.0, 8.0));
                if (c < pc.cells) {
                    first = pc.coarse_at + t * coarse_offset(pc.cells) + coarse_offset(c);
                    count = 4u * c * c;
                }
            }
            for (uint n = 0u; n < count; n++) {
                vec4 q = LT(first + n);
                k += kern(a2, r, q.xyz) * q.w;
            }
        }
        sum += k * light.rgb;
    }
    vec4 prev = imageLoad(dst, ivec3(id));
    imageStore(dst, ivec3(id), vec4(prev.rgb + sum * pc.inv_norm, prev.a));
}
