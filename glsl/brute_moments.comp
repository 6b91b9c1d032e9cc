#version 460
// Brute-force convolution from a level of the power-moment pyramid: one invocation per
// texel of level src_level (2^s × 2^s prepared texels each) writes its cone and, per channel,
// its light's power and the uniform parallelogram with the light's centroid and covariance
// (twin of moments::MomentLevel::new).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#include "mappings.glsl"
#include "kernel.glsl"

layout(local_size_x_id = 0, local_size_y = 1, local_size_z = 1) in;
layout(set = 0, binding = BINDING_BRUTE_MOM_RADIANCE, rgba32f) uniform readonly image2DArray rad;
layout(set = 0, binding = BINDING_BRUTE_MOM_SHAPES, rgba32f) uniform readonly image2DArray shapes;
layout(set = 0, binding = BINDING_BRUTE_MOM_CONES, rgba32f) uniform writeonly image2DArray cones;
layout(set = 0, binding = BINDING_BRUTE_MOM_LIGHT, rgba32f) uniform writeonly image2DArray light;

// The push block, generated from src/abi/push.rs.
PUSH_BrutePush

#include "brute_shape.glsl"
#include "brute.glsl"
#include "brute_cones.glsl"
// Per channel c: the centroid ∑ P·c_f normalised over the fine texels f, then the covariance in
// the tangent plane there, ∑ P·((e·c_f)(e′·c_f) + eᵀΣ_f e′) / ∑ P with Σ_f = (hu huᵀ + hv hvᵀ)/3,
// taken directly (no difference of large second moments), and the parallelogram √3·Σ^½.
void main() {
    uint i = gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x + gl_GlobalInvocationID.x;
    if (i >= pc.texels) return;
    uint per_layer = pc.src_size.x * pc.src_size.y;
    uint layer = i / per_layer, r = i % per_layer;
    ivec2 p = ivec2(r % pc.src_size.x, r / pc.src_size.x);
    imageStore(cones, ivec3(p, layer), texel_cone(layer, p));
    uint side = 1u << pc.src_level;
    uvec2 base = uvec2(p) * side;
    vec3 power = vec3(0.0);
    vec3 m1[3] = vec3[3](vec3(0.0), vec3(0.0), vec3(0.0));
    for (uint k = 0u; k < side * side; k++) {
        ivec2 q = ivec2(base + uvec2(k % side, k / side));
        vec4 rt = imageLoad(rad, ivec3(q, layer));
        vec3 pw = rt.rgb * rt.w;
        vec3 c = shape(ivec3(q, layer), 0).xyz;
        power += pw;
        m1[0] += pw.r * c;
        m1[1] += pw.g * c;
        m1[2] += pw.b * c;
    }
    for (int ch = 0; ch < 3; ch++) {
        // Layers 9·layer + 3·ch + 0, 1, 2 hold this channel's three vec4.
        int o = int(9u * layer) + 3 * ch;
        if (!(power[ch] > 0.0) || dot(m1[ch], m1[ch]) == 0.0) {
            imageStore(light, ivec3(p, o), vec4(0.0));
            imageStore(light, ivec3(p, o + 1), vec4(0.0));
            imageStore(light, ivec3(p, o + 2), vec4(0.0));
            continue;
        }
        vec3 cen = normalize(m1[ch]);
        vec3 e1 = normalize(abs(cen.x) < 0.9 ? cross(cen, vec3(1.0, 0.0, 0.0)) : cross(cen, vec3(0.0, 1.0, 0.0)));
        vec3 e2 = cross(cen, e1);
        vec3 cov = vec3(0.0);
        for (uint k = 0u; k < side * side; k++) {
            ivec2 q = ivec2(base + uvec2(k % side, k / side));
            vec4 rt = imageLoad(rad, ivec3(q, layer));
            float pw = rt[ch] * rt.w;
            ivec3 f = ivec3(q, layer);
            vec3 c = shape(f, 0).xyz, hu = shape(f, 1).xyz, hv = shape(f, 2).xyz;
            vec2 a = vec2(dot(e1, c), dot(e2, c));
            vec2 u = vec2(dot(e1, hu), dot(e2, hu));
            vec2 v = vec2(dot(e1, hv), dot(e2, hv));
            cov += pw * (vec3(a.x * a.x, a.x * a.y, a.y * a.y)
                + vec3(u.x * u.x + v.x * v.x, u.x * u.y + v.x * v.y, u.y * u.y + v.y * v.y) / 3.0);
        }
        vec3 sq = sqrt2(cov / power[ch]) * sqrt(3.0);
        imageStore(light, ivec3(p, o), vec4(cen, power[ch]));
        imageStore(light, ivec3(p, o + 1), vec4(e1 * sq.x + e2 * sq.y, 0.0));
        imageStore(light, ivec3(p, o + 2), vec4(e1 * sq.y + e2 * sq.z, 0.0));
    }
}
